//! One CAN segment: the nodes on it, the bit rate each node runs at, each node's parameter
//! flash and how its stores are carried out. Time is an argument; the virtual bus
//! ([`crate::bus::Bus`]) drives a segment in virtual time and the simulator (`sim`) in real
//! time, so both run the nodes the same way.

use std::any::Any;

use embedded_storage::nor_flash::NorFlash;
use od_core::lss::Lss;
use od_core::nmt::NmtState;
use od_core::node::{CanopenDevice, Context, Node, Output};
use od_core::od::GroupMask;
use od_core::storage::{Loaded, ParamFlash};
use od_core::{Bitrate, Frame, Instant};

use crate::flash::{FileFlash, RamFlash};

/// Anything that can sit on a segment: a node of any device, driven through the core's shell
/// interface ([`od_core::Station`]), with what the tests and the live view look at.
pub trait Station: od_core::Station {
    /// The node's shared state (the former name of [`od_core::Station::context`]).
    fn core(&self) -> &Context {
        self.context()
    }
    /// The NMT state, if the station is a CANopen node.
    fn nmt(&self) -> Option<NmtState> {
        None
    }
    /// The LSS slave, if the station is a CANopen node.
    fn lss(&self) -> Option<&Lss> {
        None
    }
    /// What the device shows its user (LEDs, screen) as text, if it has anything to show.
    fn panel(&self) -> Option<String> {
        None
    }
    /// The station as `Any`, for a test or the simulator to reach a concrete station (an
    /// AP10T's keys); `None` where the station does not offer it.
    fn as_any_mut(&mut self) -> Option<&mut dyn Any> {
        None
    }
}

impl<D: CanopenDevice> Station for Node<D> {
    fn nmt(&self) -> Option<NmtState> {
        Some(self.nmt_state())
    }
    fn lss(&self) -> Option<&Lss> {
        Some(Node::lss(self))
    }
}

/// A flash whose power can come back after a cut.
pub trait PowerFlash: NorFlash + 'static {
    /// The power comes back.
    fn power_on(&mut self);
}

impl PowerFlash for RamFlash {
    fn power_on(&mut self) {
        RamFlash::power_on(self)
    }
}

impl PowerFlash for FileFlash {
    fn power_on(&mut self) {
        self.ram().power_on()
    }
}

/// A node's parameter pages, whatever flash holds them.
pub trait NodeFlash {
    /// The power comes back to the flash.
    fn power_on(&mut self);
    /// What the pages hold.
    fn load(&mut self) -> Loaded;
    /// Carries out an `Output::Store`; true if it worked.
    fn save(&mut self, core: &Context, mask: GroupMask) -> bool;
    /// The concrete [`ParamFlash`], to reach the flash itself.
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<F: PowerFlash> NodeFlash for ParamFlash<F> {
    fn power_on(&mut self) {
        self.flash().power_on()
    }
    fn load(&mut self) -> Loaded {
        ParamFlash::load(self)
    }
    fn save(&mut self, core: &Context, mask: GroupMask) -> bool {
        ParamFlash::save(self, core, mask).is_ok()
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// How a node powers on from what its flash holds.
pub type Boot = Box<dyn Fn(&Loaded) -> Box<dyn Station>>;

struct Powered {
    params: Box<dyn NodeFlash>,
    boot: Boot,
}

struct Slot {
    station: Box<dyn Station>,
    bitrate: Bitrate,
    store_ok: bool,
    flash: Option<Powered>,
}

/// The nodes of one segment.
#[derive(Default)]
pub struct Segment {
    nodes: Vec<Slot>,
}

impl Segment {
    /// A segment without nodes.
    pub fn new() -> Segment {
        Segment { nodes: Vec::new() }
    }

    /// How many nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True without nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Adds a station without flash running at `bitrate`; returns its number. It boots at the
    /// next [`Segment::run_due`].
    pub fn add(&mut self, station: Box<dyn Station>, bitrate: Bitrate) -> usize {
        self.nodes.push(Slot { station, bitrate, store_ok: true, flash: None });
        self.nodes.len() - 1
    }

    /// Switches on a node whose parameters live in `params`: `boot` builds it from what they
    /// hold (now and at every [`Segment::power_cycle`]); its stores go there. It runs at the bit
    /// rate it boots with. Returns its number.
    pub fn add_with_flash(&mut self, mut params: Box<dyn NodeFlash>, boot: Boot) -> usize {
        params.power_on();
        let station = boot(&params.load());
        let bitrate = station.core().bitrate;
        self.nodes.push(Slot { station, bitrate, store_ok: true, flash: Some(Powered { params, boot }) });
        self.nodes.len() - 1
    }

    /// Switches node `n` off and on again from what its flash holds. Panics without flash.
    pub fn power_cycle(&mut self, n: usize) {
        let slot = &mut self.nodes[n];
        let flash = slot.flash.as_mut().expect("power_cycle: node has no flash");
        flash.params.power_on();
        let loaded = flash.params.load();
        slot.station = (flash.boot)(&loaded);
        slot.bitrate = slot.station.core().bitrate;
    }

    /// Node `n`'s parameter pages, if it has a flash.
    pub fn params(&mut self, n: usize) -> Option<&mut (dyn NodeFlash + 'static)> {
        self.nodes[n].flash.as_mut().map(|f| f.params.as_mut())
    }

    /// Node `n`'s flash, if it has one of type `F`.
    pub fn flash<F: PowerFlash>(&mut self, n: usize) -> Option<&mut F> {
        let params = self.params(n)?;
        params.as_any_mut().downcast_mut::<ParamFlash<F>>().map(|p| p.flash())
    }

    /// Node `n`'s station.
    pub fn station(&mut self, n: usize) -> &mut dyn Station {
        self.nodes[n].station.as_mut()
    }

    /// What node `n` shows its user (see [`Station::panel`]).
    pub fn panel(&self, n: usize) -> Option<String> {
        self.nodes[n].station.panel()
    }

    /// Node `n`'s shared state.
    pub fn core(&self, n: usize) -> &Context {
        self.nodes[n].station.core()
    }

    /// The bit rate node `n` runs at.
    pub fn bitrate(&self, n: usize) -> Bitrate {
        self.nodes[n].bitrate
    }

    /// Makes node `n`'s next stores fail (a worn-out flash) or work again.
    pub fn fail_stores(&mut self, n: usize, fail: bool) {
        self.nodes[n].store_ok = !fail;
    }

    /// The earliest deadline of any node.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.nodes.iter().filter_map(|s| s.station.next_deadline()).min()
    }

    /// A frame on the wires at `rate` at `now`, from outside or from node `from`: every other
    /// node running at `rate` receives it.
    pub fn deliver(&mut self, from: Option<usize>, frame: &Frame, rate: Bitrate, now: Instant) {
        for (i, slot) in self.nodes.iter_mut().enumerate() {
            if from != Some(i) && slot.bitrate == rate {
                slot.station.on_frame(frame, now);
            }
        }
    }

    /// Polls every node whose deadline has come and carries out outputs until the segment is
    /// quiet. A frame a node sends while at `rate` reaches the other nodes and `sent(node,
    /// frame)`; one sent at another rate is lost.
    pub fn run_due(&mut self, now: Instant, rate: Bitrate, sent: &mut dyn FnMut(usize, &Frame)) {
        loop {
            let mut progressed = false;
            for i in 0..self.nodes.len() {
                if self.nodes[i].station.next_deadline().is_some_and(|t| t <= now) {
                    self.nodes[i].station.poll(now);
                }
                while let Some(out) = self.nodes[i].station.next_output() {
                    progressed = true;
                    match out {
                        Output::Frame(f) => {
                            if self.nodes[i].bitrate == rate {
                                sent(i, &f);
                                self.deliver(Some(i), &f, rate, now);
                            }
                        }
                        Output::Store(mask) => {
                            let slot = &mut self.nodes[i];
                            let ok = slot.store_ok
                                && match &mut slot.flash {
                                    Some(f) => f.params.save(slot.station.core(), mask),
                                    None => true,
                                };
                            slot.station.store_done(if ok { Ok(()) } else { Err(()) }, now);
                        }
                        Output::SetBitrate(b) => self.nodes[i].bitrate = b,
                    }
                }
            }
            if !progressed {
                break;
            }
        }
    }
}
