//! A virtual CAN bus with a virtual clock: any number of nodes and one scripted master.
//!
//! Time only moves when the test says so ([`Bus::advance`]); every node is polled exactly at
//! its deadlines, so a scenario is replayed identically on every run.

use std::collections::VecDeque;

use od_core::storage::{Loaded, ParamFlash};
use od_core::{Bitrate, Frame, Instant};

use crate::flash::RamFlash;
use crate::segment::Segment;
pub use crate::segment::Station;

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

/// The virtual bus.
pub struct Bus {
    now: Instant,
    bitrate: Bitrate,
    nodes: Segment,
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
        Bus {
            now: Instant::ZERO,
            bitrate: Bitrate::K500,
            nodes: Segment::new(),
            inbox: VecDeque::new(),
            log: Vec::new(),
        }
    }

    /// Adds a station (running at the bus's bit rate) and lets it boot; returns its number.
    pub fn add(&mut self, station: impl Station + 'static) -> usize {
        let n = self.nodes.add(Box::new(station), self.bitrate);
        self.run_due();
        n
    }

    /// Adds a node with a parameter flash and switches it on: `boot` builds it from what
    /// `params` holds (now and at every [`Bus::power_cycle`]), and its `Output::Store`s are
    /// saved there. It runs at the bit rate it boots with. Returns its number.
    pub fn add_with_flash<S: Station + 'static>(
        &mut self,
        params: ParamFlash<RamFlash>,
        boot: impl Fn(&Loaded) -> S + 'static,
    ) -> usize {
        let n = self.nodes.add_with_flash(Box::new(params), Box::new(move |l| Box::new(boot(l))));
        self.run_due();
        n
    }

    /// Switches node `n` off and on again: the power comes back to its flash (after a cut),
    /// and the node boots from what the flash holds. Panics if the node has no flash.
    pub fn power_cycle(&mut self, n: usize) {
        self.nodes.power_cycle(n);
        self.run_due();
    }

    /// Node `n`'s parameter flash (to cut its power, wear it out or corrupt it). Panics if the
    /// node has none.
    pub fn flash(&mut self, n: usize) -> &mut RamFlash {
        self.nodes.flash::<RamFlash>(n).expect("node has no flash")
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
        self.nodes.bitrate(n)
    }

    /// Makes node `n`'s next stores fail (a worn-out flash).
    pub fn fail_stores(&mut self, n: usize, fail: bool) {
        self.nodes.fail_stores(n, fail);
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
            let next = self.nodes.next_deadline();
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
        self.nodes.station(n)
    }

    fn deliver(&mut self, from: Sender, frame: Frame) {
        let seen = Seen { at: self.now, from, frame };
        self.log.push(seen);
        let node = match from {
            Sender::Master => None,
            Sender::Node(i) => {
                self.inbox.push_back(seen);
                Some(i)
            }
        };
        self.nodes.deliver(node, &frame, self.bitrate, self.now);
    }

    /// Polls every node whose deadline has come and carries out outputs until the bus is quiet.
    fn run_due(&mut self) {
        let (now, log, inbox) = (self.now, &mut self.log, &mut self.inbox);
        self.nodes.run_due(now, self.bitrate, &mut |i, f| {
            let seen = Seen { at: now, from: Sender::Node(i), frame: *f };
            log.push(seen);
            inbox.push_back(seen);
        });
    }
}
