//! A virtual CAN bus with a virtual clock: any number of nodes and one scripted master.
//!
//! Time only moves when the test says so ([`Bus::advance`]); every node is polled exactly at
//! its deadlines, so a scenario is replayed identically on every run.

use std::collections::VecDeque;

use od_core::node::{Core, Device, Node, Output};
use od_core::storage::{Loaded, ParamFlash};
use od_core::{Bitrate, Frame, Instant};

use crate::flash::RamFlash;

/// Anything that can sit on the virtual bus: a node of any device.
pub trait Station {
    /// A frame from the bus.
    fn on_frame(&mut self, frame: &Frame, now: Instant);
    /// Timers.
    fn poll(&mut self, now: Instant);
    /// When `poll` must next run.
    fn next_deadline(&self) -> Option<Instant>;
    /// The next output.
    fn next_output(&mut self) -> Option<Output>;
    /// Report the result of an `Output::Store`.
    fn store_done(&mut self, ok: bool, now: Instant);
    /// The node's shared state (what a store persists).
    fn core(&self) -> &Core;
}

impl<D: Device> Station for Node<D> {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        Node::on_frame(self, frame, now)
    }
    fn poll(&mut self, now: Instant) {
        Node::poll(self, now)
    }
    fn next_deadline(&self) -> Option<Instant> {
        Node::next_deadline(self)
    }
    fn next_output(&mut self) -> Option<Output> {
        Node::next_output(self)
    }
    fn store_done(&mut self, ok: bool, now: Instant) {
        Node::store_done(self, if ok { Ok(()) } else { Err(()) }, now)
    }
    fn core(&self) -> &Core {
        Node::core(self)
    }
}

/// Who put a frame on the bus.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Sender {
    /// The scripted master.
    Master,
    /// Node number `n` (in the order of [`Bus::add`]).
    Node(usize),
}

/// One frame seen on the bus.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Seen {
    /// When.
    pub at: Instant,
    /// Who sent it.
    pub from: Sender,
    /// The frame.
    pub frame: Frame,
}

struct Slot {
    station: Box<dyn Station>,
    bitrate: Bitrate,
    store_ok: bool,
    flash: Option<Flash>,
}

/// How a node powers on from what its flash holds.
type Boot = Box<dyn Fn(&Loaded) -> Box<dyn Station>>;

/// A node's parameter flash and how the node powers on from it.
struct Flash {
    params: ParamFlash<RamFlash>,
    boot: Boot,
}

/// The virtual bus.
pub struct Bus {
    now: Instant,
    bitrate: Bitrate,
    nodes: Vec<Slot>,
    /// Frames the master has received and not yet taken.
    inbox: VecDeque<Seen>,
    /// Every frame, in bus order.
    pub log: Vec<Seen>,
}

impl Default for Bus {
    fn default() -> Self {
        Bus::new()
    }
}

impl Bus {
    /// An empty bus at 500 kbit/s at time zero.
    pub fn new() -> Bus {
        Bus { now: Instant::ZERO, bitrate: Bitrate::K500, nodes: Vec::new(), inbox: VecDeque::new(), log: Vec::new() }
    }

    /// Adds a station (running at the bus's bit rate) and lets it boot; returns its number.
    pub fn add(&mut self, station: impl Station + 'static) -> usize {
        self.nodes.push(Slot { station: Box::new(station), bitrate: self.bitrate, store_ok: true, flash: None });
        let n = self.nodes.len() - 1;
        self.run_due();
        n
    }

    /// Adds a node with a parameter flash and switches it on: `boot` builds it from what
    /// `params` holds (now and at every [`Bus::power_cycle`]), and its `Output::Store`s are
    /// saved there. It runs at the bit rate it boots with. Returns its number.
    pub fn add_with_flash<S: Station + 'static>(
        &mut self,
        mut params: ParamFlash<RamFlash>,
        boot: impl Fn(&Loaded) -> S + 'static,
    ) -> usize {
        params.flash().power_on();
        let station: Box<dyn Station> = Box::new(boot(&params.load()));
        let bitrate = station.core().bitrate;
        let flash = Flash { params, boot: Box::new(move |l| Box::new(boot(l))) };
        self.nodes.push(Slot { station, bitrate, store_ok: true, flash: Some(flash) });
        let n = self.nodes.len() - 1;
        self.run_due();
        n
    }

    /// Switches node `n` off and on again: the power comes back to its flash (after a cut),
    /// and the node boots from what the flash holds. Panics if the node has no flash.
    pub fn power_cycle(&mut self, n: usize) {
        let slot = &mut self.nodes[n];
        let flash = slot.flash.as_mut().expect("power_cycle: node has no flash");
        flash.params.flash().power_on();
        let loaded = flash.params.load();
        slot.station = (flash.boot)(&loaded);
        slot.bitrate = slot.station.core().bitrate;
        self.run_due();
    }

    /// Node `n`'s parameter flash (to cut its power, wear it out or corrupt it). Panics if the
    /// node has none.
    pub fn flash(&mut self, n: usize) -> &mut RamFlash {
        self.nodes[n].flash.as_mut().expect("node has no flash").params.flash()
    }

    /// The current virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// The bus's bit rate.
    pub fn bitrate(&self) -> Bitrate {
        self.bitrate
    }

    /// Changes the bus's bit rate (the master's and the wires'); nodes at another rate
    /// neither see nor send frames.
    pub fn set_bitrate(&mut self, bitrate: Bitrate) {
        self.bitrate = bitrate;
    }

    /// The bit rate node `n` runs at.
    pub fn node_bitrate(&self, n: usize) -> Bitrate {
        self.nodes[n].bitrate
    }

    /// Makes node `n`'s next stores fail (a worn-out flash).
    pub fn fail_stores(&mut self, n: usize, fail: bool) {
        self.nodes[n].store_ok = !fail;
    }

    /// The master sends `frame` now; every node handles it and answers.
    pub fn send(&mut self, frame: Frame) {
        self.deliver(Sender::Master, frame);
        self.run_due();
    }

    /// Moves virtual time forward by `ms` milliseconds, polling every node at its deadlines.
    pub fn advance(&mut self, ms: u64) {
        self.advance_to(self.now.add_millis(ms));
    }

    /// Moves virtual time forward by `us` microseconds.
    pub fn advance_micros(&mut self, us: u64) {
        self.advance_to(self.now.add_micros(us));
    }

    /// Moves virtual time forward to `until`.
    pub fn advance_to(&mut self, until: Instant) {
        loop {
            self.run_due();
            let next = self.nodes.iter().filter_map(|s| s.station.next_deadline()).min();
            match next {
                Some(t) if t <= self.now => {
                    panic!("a node's deadline {t:?} stays due at {:?} after its poll", self.now)
                }
                Some(t) if t <= until => self.now = t,
                _ => break,
            }
        }
        self.now = self.now.max(until);
        self.run_due();
    }

    /// Takes the oldest frame the master has received.
    pub fn recv(&mut self) -> Option<Seen> {
        self.inbox.pop_front()
    }

    /// Takes every frame the master has received.
    pub fn drain(&mut self) -> Vec<Seen> {
        self.inbox.drain(..).collect()
    }

    /// Takes the next received frame and checks its identifier and data; panics with the
    /// difference otherwise. Returns it for further checks.
    #[track_caller]
    pub fn expect(&mut self, id: u16, data: &[u8]) -> Seen {
        let seen = self.recv().unwrap_or_else(|| panic!("expected {id:03X} {data:02X?}, bus is silent"));
        assert_eq!(
            (seen.frame.id, seen.frame.rtr, seen.frame.payload()),
            (od_core::CanId::Std(id), false, data),
            "at {} us",
            seen.at.as_micros()
        );
        seen
    }

    /// Checks that the master has received nothing.
    #[track_caller]
    pub fn expect_silence(&mut self) {
        if let Some(s) = self.recv() {
            panic!("expected silence, got {:?} at {} us", s.frame, s.at.as_micros());
        }
    }

    /// Direct access to node `n`'s station.
    pub fn station(&mut self, n: usize) -> &mut dyn Station {
        self.nodes[n].station.as_mut()
    }

    fn deliver(&mut self, from: Sender, frame: Frame) {
        let seen = Seen { at: self.now, from, frame };
        self.log.push(seen);
        if from != Sender::Master {
            self.inbox.push_back(seen);
        }
        let now = self.now;
        let bitrate = self.bitrate;
        for (i, slot) in self.nodes.iter_mut().enumerate() {
            if from != Sender::Node(i) && slot.bitrate == bitrate {
                slot.station.on_frame(&frame, now);
            }
        }
    }

    /// Polls every node whose deadline has come and carries out outputs until the bus is quiet.
    fn run_due(&mut self) {
        loop {
            let mut progressed = false;
            for i in 0..self.nodes.len() {
                let now = self.now;
                if self.nodes[i].station.next_deadline().is_some_and(|t| t <= now) {
                    self.nodes[i].station.poll(now);
                }
                while let Some(out) = self.nodes[i].station.next_output() {
                    progressed = true;
                    match out {
                        Output::Frame(f) => {
                            if self.nodes[i].bitrate == self.bitrate {
                                self.deliver(Sender::Node(i), f);
                            }
                        }
                        Output::Store(mask) => {
                            let slot = &mut self.nodes[i];
                            let ok = slot.store_ok
                                && match &mut slot.flash {
                                    Some(f) => f.params.save(slot.station.core(), mask).is_ok(),
                                    None => true,
                                };
                            slot.station.store_done(ok, now);
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
