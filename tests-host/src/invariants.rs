//! Stress harness: a node of each device kind driven by any sequence of inputs with any timing,
//! and a checker that, after every input, verifies what must always hold (issue 15):
//!
//! - no panic (the caller sees it);
//! - every dictionary value within its declared type and limits;
//! - the stored image changes only through a valid save (1010h "save") or LSS store
//!   configuration, and the next power-on has exactly what those stored;
//! - the node transmits only on identifiers it owns (SDO 580h, error control 700h, EMCY and
//!   TPDO COB-IDs from its dictionary, LSS 7E4h), each in an NMT state that allows it;
//! - every SDO request gets at most one answer (exactly one unless the protocol says none), a
//!   transfer left open is aborted with 05040000h after the timeout, and the server is idle
//!   again;
//! - NMT and LSS states change only on the inputs that may change them; the node-ID stays
//!   1..=127 or FFh; a poll never leaves its own deadline due.
//!
//! Inputs come from [`Client::decode`], which turns any bytes into actions biased toward the
//! node's own identifiers and valid command bytes (SDO segmented transfers, LSS configuration,
//! NMT resets, PDO configuration writes, saves), so that random bytes reach deep states. The
//! stable proptest (`tests/fuzz_props.rs`) and the cargo-fuzz targets (`fuzz/`) share it.
//!
//! The device kinds are listed once in [`KINDS`]; a new CANopen device joins with its
//! [`Kind`] variant, one line in [`KINDS`] and one arm in [`Kind::boot`]. The WV58MR, a J1939
//! node, has its own rig and checks in [`j1939`], over the same actions and decoder. The AP10T
//! is one of [`KINDS`]: its keys are its own input ([`KeyedAp10t`]), and the checker knows what
//! only it does: a frame during the bit-rate detection only proves the rate, the external
//! heartbeat (5F09h) running out sends it to PRE-OPERATIONAL, a remote frame on RPDO1/RPDO2
//! in OPERATIONAL is answered on its own identifier (the set point read back), an auto-ID write
//! is answered at the key or when the node-ID's store it asks for is done, and the key menu
//! asks for its own stores (the node-ID or bit rate alone, which the next power-on must find).

use std::collections::HashMap;
use std::fmt;

use od_core::devices::{ap10t, sgh10, sgh50, wv5800m};
use od_core::encoder::{Encoder, SensorFault};
use od_core::lss::Lss;
use od_core::node::{BusEvent, CanError, CanopenDevice, Core, Node, Output};
use od_core::od::{DataType, Entry, Group, GroupMask, Hook};
use od_core::storage::{identity, Image, Loaded, ParamFlash, Record, Region};
use od_core::{CanId, Frame, Instant, NmtState};

use crate::flash::RamFlash;

pub mod j1939;

/// The parameter pages the harness gives every node: three pages, as the firmware's ring.
pub const REGION: Region = Region { offset: 0, pages: 3 };

/// SDO server timeout (D-SDO-3).
const SDO_TIMEOUT_US: u64 = 1_000_000;

/// A device kind the stress tests cover.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    /// SGH10.
    Sgh10,
    /// SGH50, non-redundant.
    Sgh50Single,
    /// SGH50 redundant, first encoder.
    Sgh50First,
    /// SGH50 redundant, second encoder.
    Sgh50Second,
    /// WV5800M, 4096 turns.
    Wv5800m,
    /// WH5800M singleturn.
    Wh5800mSingle,
    /// AP10T display.
    Ap10t,
}

/// The encoder kinds: the power-cut and bus-load scenarios (encoder objects, TPDO1 timing) run
/// on these.
pub const ENCODERS: &[Kind] =
    &[Kind::Sgh10, Kind::Sgh50Single, Kind::Sgh50First, Kind::Sgh50Second, Kind::Wv5800m, Kind::Wh5800mSingle];

/// Every kind, in the order the proptest and the fuzz targets pick them.
pub const KINDS: &[Kind] = &[
    Kind::Sgh10,
    Kind::Sgh50Single,
    Kind::Sgh50First,
    Kind::Sgh50Second,
    Kind::Wv5800m,
    Kind::Wh5800mSingle,
    Kind::Ap10t,
];

impl Kind {
    /// The kind's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Sgh10 => "SGH10",
            Kind::Sgh50Single => "SGH50",
            Kind::Sgh50First => "SGH50 redundant #1",
            Kind::Sgh50Second => "SGH50 redundant #2",
            Kind::Wv5800m => "WV5800M",
            Kind::Wh5800mSingle => "WH5800M-1",
            Kind::Ap10t => "AP10T",
        }
    }

    fn wv(model: wv5800m::Model, turns: wv5800m::Turns) -> wv5800m::Wv5800m {
        wv5800m::Wv5800m::new(wv5800m::Variant { model, turns })
    }

    /// A node of this kind powered on from `loaded`.
    pub fn boot(self, loaded: &Loaded) -> Box<dyn Subject> {
        use wv5800m::{Model, Turns};
        match self {
            Kind::Sgh10 => Box::new(Node::boot(sgh10::Sgh10::new(sgh10::Variant::Sgh10), loaded)),
            Kind::Sgh50Single => Box::new(Node::boot(sgh50::Sgh50::new(sgh50::Variant::Single), loaded)),
            Kind::Sgh50First => {
                Box::new(Node::boot(sgh50::Sgh50::new(sgh50::Variant::Redundant(sgh50::Channel::First)), loaded))
            }
            Kind::Sgh50Second => {
                Box::new(Node::boot(sgh50::Sgh50::new(sgh50::Variant::Redundant(sgh50::Channel::Second)), loaded))
            }
            Kind::Wv5800m => Box::new(Node::boot(Kind::wv(Model::Wv, Turns::Multi12), loaded)),
            Kind::Wh5800mSingle => Box::new(Node::boot(Kind::wv(Model::Wh, Turns::Single), loaded)),
            Kind::Ap10t => Box::new(KeyedAp10t(Node::boot(ap10t::Ap10t::new(), loaded))),
        }
    }

    /// Does the kind serve LSS? (The AP10T has none: `CanopenDevice::has_lss`.)
    pub fn has_lss(self) -> bool {
        self != Kind::Ap10t
    }

    /// Does the kind serve segmented SDO transfers? (The AP10T's server is expedited only:
    /// `CanopenDevice::sdo_expedited_only`.)
    pub fn segmented_sdo(self) -> bool {
        self != Kind::Ap10t
    }

    /// The kind's dictionary.
    pub fn table(self) -> &'static [Entry] {
        self.boot(&Loaded::Blank).core().od.table()
    }
}

/// What the harness needs of a node of any kind: the node's public API and the device's own
/// inputs (a sensor sample for an encoder).
pub trait Subject {
    /// [`Node::on_frame`].
    fn on_frame(&mut self, frame: &Frame, now: Instant);
    /// [`Node::poll`].
    fn poll(&mut self, now: Instant);
    /// [`Node::next_deadline`].
    fn next_deadline(&self) -> Option<Instant>;
    /// [`Node::next_output`].
    fn next_output(&mut self) -> Option<Output>;
    /// [`Node::store_done`].
    fn store_done(&mut self, ok: bool, now: Instant);
    /// [`Node::on_bus_event`].
    fn on_bus_event(&mut self, event: BusEvent, now: Instant);
    /// The device's own input: a sensor reading (raw count, or a fault).
    fn sample(&mut self, raw: Result<u32, SensorFault>, now: Instant);
    /// [`Node::core`].
    fn core(&self) -> &Core;
    /// [`Node::lss`].
    fn lss(&self) -> &Lss;
    /// [`Node::nmt_state`].
    fn nmt_state(&self) -> NmtState;
    /// [`Node::listen_only`]: detecting the bit rate, the node only listens.
    fn listen_only(&self) -> bool {
        false
    }
}

impl<E: Encoder + CanopenDevice> Subject for Node<E> {
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
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        Node::on_bus_event(self, event, now)
    }
    fn sample(&mut self, raw: Result<u32, SensorFault>, now: Instant) {
        let (device, core) = self.split();
        device.on_sample(core, raw, now);
    }
    fn core(&self) -> &Core {
        Node::core(self)
    }
    fn lss(&self) -> &Lss {
        Node::lss(self)
    }
    fn nmt_state(&self) -> NmtState {
        Node::nmt_state(self)
    }
}

/// An AP10T node. Its own input is its keys: a "sample" `raw` presses (bit 2 clear) or
/// releases (bit 2 set) key `raw & 3`; a fault releases every key.
pub struct KeyedAp10t(pub Node<ap10t::Ap10t>);

impl Subject for KeyedAp10t {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.0.on_frame(frame, now)
    }
    fn poll(&mut self, now: Instant) {
        self.0.poll(now)
    }
    fn next_deadline(&self) -> Option<Instant> {
        self.0.next_deadline()
    }
    fn next_output(&mut self) -> Option<Output> {
        self.0.next_output()
    }
    fn store_done(&mut self, ok: bool, now: Instant) {
        self.0.store_done(if ok { Ok(()) } else { Err(()) }, now)
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.0.on_bus_event(event, now)
    }
    fn sample(&mut self, raw: Result<u32, SensorFault>, now: Instant) {
        use ap10t::Key;
        const KEYS: [Key; 4] = [Key::Front, Key::Left, Key::Star, Key::Up];
        let (device, core) = self.0.split();
        match raw {
            Ok(r) if r & 4 == 0 => device.press(core, KEYS[r as usize & 3], now),
            Ok(r) => device.release(core, KEYS[r as usize & 3], now),
            Err(_) => KEYS.iter().for_each(|&k| device.release(core, k, now)),
        }
    }
    fn core(&self) -> &Core {
        self.0.core()
    }
    fn lss(&self) -> &Lss {
        self.0.lss()
    }
    fn nmt_state(&self) -> NmtState {
        self.0.nmt_state()
    }
    fn listen_only(&self) -> bool {
        self.0.listen_only()
    }
}

/// One input to the node.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Action {
    /// A frame from another node.
    Frame(Frame),
    /// Virtual time moves on by this many microseconds; the node is polled at each of its
    /// deadlines on the way (at most [`MAX_POLLS_PER_ADVANCE`], then once at the end).
    Advance(u64),
    /// Virtual time jumps this far and the node is polled once, late.
    LatePoll(u64),
    /// The shell finishes the oldest pending store: writes the flash (true) or fails.
    StoreDone(bool),
    /// The CAN controller reports an event.
    Bus(BusEvent),
    /// A sensor sample.
    Sample(Result<u32, SensorFault>),
    /// Power off and on: the node boots from its flash.
    PowerCycle,
}

/// Most polls one [`Action::Advance`] performs at the node's deadlines.
pub const MAX_POLLS_PER_ADVANCE: usize = 4000;

/// Reads actions from any bytes.
pub struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    /// Over `data`.
    pub fn new(data: &'a [u8]) -> Bytes<'a> {
        Bytes { data, pos: 0 }
    }
    /// Anything left?
    pub fn is_empty(&self) -> bool {
        self.pos >= self.data.len()
    }
    /// The next byte (0 past the end).
    pub fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }
    /// True once in `n` (by the next byte).
    fn one_in(&mut self, n: u8) -> bool {
        self.u8().is_multiple_of(n)
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
}

/// The client state the decoder needs to build sensible requests: the toggle of the
/// segmented transfer it runs, and what the node's dictionary and identity are.
pub struct Client {
    table: &'static [Entry],
    toggle: u8,
    /// The segmented download the client runs: the value it sends.
    down: Option<([u8; 7], usize)>,
    /// The rest of a multi-frame script (a PDO remap, a full LSS configuration).
    script: std::collections::VecDeque<Action>,
    /// The node-ID the client addresses (the node's active one, read before each action).
    pub node_id: u8,
    /// The node's LSS address (1018h.01..04).
    pub identity: [u32; 4],
}

impl Client {
    /// A client of a node with dictionary `table`.
    pub fn new(table: &'static [Entry]) -> Client {
        Client { table, toggle: 0, down: None, script: Default::default(), node_id: 1, identity: [0; 4] }
    }

    /// Updates what the client knows of the node.
    pub fn observe(&mut self, core: &Core) {
        if (1..=127).contains(&core.node_id) {
            self.node_id = core.node_id;
        }
        for (k, v) in self.identity.iter_mut().enumerate() {
            *v = core.od.value(0x1018, k as u8 + 1).unwrap_or(0);
        }
    }

    fn entry(&self, b: &mut Bytes) -> &'static Entry {
        &self.table[b.u8() as usize % self.table.len()]
    }

    /// A value for `e`: mostly near its limits or default, sometimes anything.
    fn value(&self, e: &Entry, b: &mut Bytes) -> u32 {
        let pick = b.u8();
        let (lo, hi) = e.limits().unwrap_or((0, 0));
        match pick % 8 {
            0 => lo as u32,
            1 => hi as u32,
            2 => (lo as u32).wrapping_sub(1),
            3 => (hi as u32).wrapping_add(1),
            4 => e.default_value(self.node_id),
            5 => b.u8() as u32,
            6 => {
                // A COB-ID near the node's own identifiers, valid or not.
                let base = [0x180u32, 0x280, 0x380, 0x480, 0x80, 0x580, 0x600, 0x700][b.u8() as usize % 8];
                let flags = [0, 0x8000_0000, 0x4000_0000, 0x2000_0000, 0xC000_0000][b.u8() as usize % 5];
                flags | (base + self.node_id as u32 + (b.u8() % 3) as u32).wrapping_sub(1)
            }
            _ => b.u32(),
        }
    }

    fn sdo(&self, data: [u8; 8]) -> Frame {
        Frame::std(0x600 + self.node_id as u16, &data)
    }

    /// Decodes the next action; `None` when the bytes are used up.
    pub fn decode(&mut self, b: &mut Bytes) -> Option<Action> {
        if b.is_empty() {
            return None;
        }
        // A script runs on unless the fuzzer interrupts it (one byte in eight).
        if !self.script.is_empty() && !b.one_in(8) {
            return self.script.pop_front();
        }
        let id = self.node_id as u16;
        let op = b.u8();
        Some(match op % 32 {
            // SDO expedited write of a dictionary entry, with a value near its limits.
            0..=4 => {
                let e = self.entry(b);
                let v = self.value(e, b);
                let size = e.dtype.size().clamp(1, 4);
                let size = if b.one_in(8) { (b.u8() % 4 + 1) as usize } else { size };
                let mut req = crate::encoder::download_request(e.index, e.sub, size, v);
                if b.one_in(8) {
                    req[0] = 0x22; // no size indicated
                }
                self.toggle = 0;
                Action::Frame(self.sdo(req))
            }
            // SDO read of a dictionary entry (strings are segmented).
            5 | 6 => {
                let e = self.entry(b);
                self.toggle = 0;
                Action::Frame(self.sdo(crate::encoder::upload_request(e.index, e.sub)))
            }
            // Upload segment with the expected toggle (sometimes the wrong one).
            7 => {
                let t = if b.one_in(8) { self.toggle ^ 0x10 } else { self.toggle };
                self.toggle ^= 0x10;
                Action::Frame(self.sdo([0x60 | t, 0, 0, 0, 0, 0, 0, 0]))
            }
            // Segmented download initiate (size indicated or not) of an entry or 1010h "save",
            // mostly with the size the value has.
            8 => {
                let e = self.entry(b);
                let save = b.one_in(2);
                let (index, sub) = if save { (0x1010, b.u8() % 5) } else { (e.index, e.sub) };
                let mut value = [0u8; 7];
                let size = if save {
                    value[..4].copy_from_slice(b"save");
                    4
                } else {
                    value[..4].copy_from_slice(&self.value(e, b).to_le_bytes());
                    e.dtype.size().clamp(1, 4)
                };
                let size = if b.one_in(8) { (b.u8() % 12) as usize } else { size };
                self.down = Some((value, size));
                let i = index.to_le_bytes();
                let sz = (size as u32).to_le_bytes();
                let cs = if b.one_in(4) { 0x20 } else { 0x21 };
                self.toggle = 0;
                Action::Frame(self.sdo([cs, i[0], i[1], sub, sz[0], sz[1], sz[2], sz[3]]))
            }
            // Download segment: the client's value as the last segment, or any bytes, last or
            // not; the right toggle mostly.
            9 | 10 => {
                let t = if b.one_in(8) { self.toggle ^ 0x10 } else { self.toggle };
                self.toggle ^= 0x10;
                let flags = b.u8();
                let mut d = [0u8; 8];
                let (n, last) = match self.down.take() {
                    Some((v, size)) if flags & 0x40 == 0 => {
                        let n = if flags & 0x20 == 0 { size.min(7) } else { (flags % 8) as usize };
                        d[1..8].copy_from_slice(&v);
                        (n, true)
                    }
                    _ => {
                        for x in d[1..8].iter_mut() {
                            *x = b.u8();
                        }
                        ((flags % 8) as usize, flags & 0x80 != 0)
                    }
                };
                d[0] = t | (((7 - n.min(7)) as u8) << 1) | last as u8;
                Action::Frame(self.sdo(d))
            }
            // 1010h "save" / 1011h "load" on any sub-index (sometimes a wrong signature).
            11 => {
                let index = if b.one_in(3) { 0x1011 } else { 0x1010 };
                let sig = match (index, b.u8() % 6) {
                    (_, 0) => b.u32(),
                    (0x1010, _) => u32::from_le_bytes(*b"save"),
                    _ => u32::from_le_bytes(*b"load"),
                };
                Action::Frame(self.sdo(crate::encoder::download_request(index, b.u8() % 6, 4, sig)))
            }
            // Client abort, or any SDO bytes.
            12 => {
                let mut d = [0u8; 8];
                for x in d.iter_mut() {
                    *x = b.u8();
                }
                if b.one_in(2) {
                    d[0] = 0x80;
                }
                let len = if b.one_in(8) { b.u8() % 9 } else { 8 };
                Action::Frame(Frame::std(0x600 + id, &d[..len as usize]))
            }
            // NMT to this node, to all, to another, or malformed.
            13 | 14 => {
                let cs = [0x01, 0x02, 0x80, 0x81, 0x82, 0x01, 0x80, 0x82][b.u8() as usize % 8];
                let cs = if b.one_in(16) { b.u8() } else { cs };
                let target = match b.u8() % 4 {
                    0 => 0,
                    1 | 2 => self.node_id,
                    _ => b.u8(),
                };
                let len = if b.one_in(16) { b.u8() % 9 } else { 2 };
                let d = [cs, target, b.u8(), 0, 0, 0, 0, 0];
                Action::Frame(Frame::std(0, &d[..len as usize]))
            }
            // LSS: the services with valid command bytes and the node's own identity.
            15..=17 => Action::Frame(self.lss(b)),
            // SYNC, on its default identifier or a neighbour, with or without a counter.
            18 => {
                let id = if b.one_in(4) { 0x80 + (b.u8() % 3) as u16 - 1 } else { 0x80 };
                let len = b.u8() % 3;
                Action::Frame(Frame::std(id, &[b.u8(), b.u8()][..len as usize]))
            }
            // Remote frames on the node's identifiers (guarding, TPDOs, SDO, EMCY).
            19 => {
                let base = [0x700, 0x180, 0x280, 0x380, 0x480, 0x580, 0x600, 0x080][b.u8() as usize % 8];
                Action::Frame(Frame::remote(CanId::Std(base + id), b.u8() % 9))
            }
            // Frames on the node's identifiers and their neighbours, any payload.
            20 => {
                let base = [0x180, 0x200, 0x280, 0x300, 0x580, 0x600, 0x700, 0x7E4, 0x7E5, 0x000][b.u8() as usize % 10];
                let raw = (base + id).wrapping_add((b.u8() % 5) as u16).wrapping_sub(2) & 0x7FF;
                let len = b.u8() % 9;
                let d = [b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8()];
                Action::Frame(Frame::std(raw, &d[..len as usize]))
            }
            // Any frame, standard or extended.
            21 => {
                let raw = b.u32();
                let len = b.u8() % 9;
                let d = [b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8()];
                let can =
                    if raw & 1 << 31 != 0 { CanId::Ext(raw & 0x1FFF_FFFF) } else { CanId::Std((raw & 0x7FF) as u16) };
                if raw & 1 << 30 != 0 {
                    Action::Frame(Frame::remote(can, len))
                } else {
                    Action::Frame(Frame::new(can, &d[..len as usize]))
                }
            }
            // Time: microseconds, milliseconds, seconds.
            22..=24 => Action::Advance(match b.u8() % 4 {
                0 => b.u8() as u64,
                1 => b.u16() as u64 * 10,
                2 => b.u16() as u64 * 100,
                _ => SDO_TIMEOUT_US + b.u8() as u64 * 1000,
            }),
            25 => Action::LatePoll(b.u16() as u64 * 100),
            26 | 27 => Action::StoreDone(!b.one_in(4)),
            28 => Action::Bus(match b.u8() % 8 {
                0 => BusEvent::ErrorPassive,
                1 => BusEvent::ErrorActive,
                2 => BusEvent::BusOff,
                3 => BusEvent::BusOffRecovered,
                4 => BusEvent::RxOverrun,
                5 => BusEvent::ErrorCounters { rx: b.u8(), tx: b.u8() },
                _ => BusEvent::ProtocolError(
                    [CanError::Stuff, CanError::Form, CanError::Acknowledge, CanError::Bit, CanError::Crc]
                        [b.u8() as usize % 5],
                ),
            }),
            29 | 30 => Action::Sample(match b.u8() % 8 {
                0 => Err(SensorFault::Diagnosis),
                1 => Err(SensorFault::NoResponse),
                2 => Err(SensorFault::OutOfRange),
                3 => Ok(b.u32()),
                _ => Ok(b.u16() as u32 * (1 + b.u8() as u32 % 64)),
            }),
            _ if b.one_in(2) => Action::PowerCycle,
            _ => {
                self.script = self.script(b);
                self.script.pop_front()?
            }
        })
    }

    /// A multi-frame sequence a master runs: a TPDO remapped to another mappable entry and
    /// started, a full LSS configuration with the node's address (selective switch, node-ID,
    /// bit timing, store, back to waiting, reset), or a segmented 1010h save.
    fn script(&self, b: &mut Bytes) -> std::collections::VecDeque<Action> {
        let id = self.node_id as u32;
        let sdo = |d: [u8; 8]| Action::Frame(self.sdo(d));
        let write = |i: u16, s: u8, n: usize, v: u32| sdo(crate::encoder::download_request(i, s, n, v));
        let lss = |d: [u8; 8]| Action::Frame(Frame::std(0x7E5, &d));
        let mut out = std::collections::VecDeque::new();
        match b.u8() % 3 {
            0 => {
                let n = (b.u8() % 2) as u16;
                let mappable: Vec<&Entry> = self.table.iter().filter(|e| e.pdo).collect();
                let e = mappable.get(b.u8() as usize % mappable.len().max(1)).copied();
                let map = e.map_or(0, |e| (e.index as u32) << 16 | (e.sub as u32) << 8 | e.dtype.bits() as u32);
                let cob = 0x180 + 0x100 * n as u32 + id;
                out.extend([
                    write(0x1800 + n, 1, 4, cob | 0x8000_0000),
                    write(0x1A00 + n, 0, 1, 0),
                    write(0x1A00 + n, 1, 4, map),
                    write(0x1A00 + n, 0, 1, 1),
                    write(0x1800 + n, 2, 1, [0x01, 0xFE, 0xFF, 0x05][b.u8() as usize % 4]),
                    write(0x1800 + n, 1, 4, cob),
                    Action::Frame(Frame::std(0, &[0x01, self.node_id])),
                    Action::Advance(20_000),
                    Action::Frame(Frame::std(0x80, &[])),
                ]);
            }
            1 => {
                for (k, v) in self.identity.iter().enumerate() {
                    let v = v.to_le_bytes();
                    out.push_back(lss([0x40 + k as u8, v[0], v[1], v[2], v[3], 0, 0, 0]));
                }
                out.extend([
                    lss([0x11, 1 + b.u8() % 127, 0, 0, 0, 0, 0, 0]),
                    lss([0x13, 0, b.u8() % 9, 0, 0, 0, 0, 0]),
                    lss([0x17, 0, 0, 0, 0, 0, 0, 0]),
                    Action::StoreDone(true),
                    lss([0x04, 0, 0, 0, 0, 0, 0, 0]),
                    Action::Frame(Frame::std(0, &[0x82, 0])),
                    Action::Advance(1000),
                ]);
            }
            _ => {
                let sub = 1 + b.u8() % 4;
                out.extend([
                    sdo([0x21, 0x10, 0x10, sub, 4, 0, 0, 0]),
                    sdo([0x07, b's', b'a', b'v', b'e', 0, 0, 0]), // last segment, 4 bytes
                    Action::StoreDone(true),
                    Action::Frame(Frame::std(0, &[0x81, self.node_id])),
                    Action::Advance(1000),
                ]);
            }
        }
        out
    }

    fn lss(&self, b: &mut Bytes) -> Frame {
        let mut d = [0u8; 8];
        let part = b.u8() as usize % 4;
        let right = !b.one_in(8);
        let value = if right { self.identity[part] } else { b.u32() };
        match b.u8() % 12 {
            0 => {
                d[0] = 0x04;
                d[1] = if b.one_in(8) { b.u8() } else { b.u8() % 2 };
            }
            // The four switch-state-selective frames with the node's address, in one go
            // would be four actions; one of them at a time, in order when the fuzzer repeats.
            1 | 2 => {
                d[0] = 0x40 + part as u8;
                d[1..5].copy_from_slice(&value.to_le_bytes());
            }
            3 => {
                d[0] = 0x11;
                d[1] = match b.u8() % 4 {
                    0 => 0xFF,
                    1 => b.u8(),
                    _ => 1 + b.u8() % 127,
                };
            }
            4 => {
                d[0] = 0x13;
                d[1] = b.u8() % 2;
                d[2] = b.u8() % 10;
            }
            5 => {
                d[0] = 0x15;
                d[1..3].copy_from_slice(&(b.u8() as u16 % 50).to_le_bytes());
            }
            6 => d[0] = 0x17,
            7 => d[0] = 0x5A + part as u8,
            8 => d[0] = 0x5E,
            9 => {
                d[0] = 0x46 + b.u8() % 6;
                d[1..5].copy_from_slice(&value.to_le_bytes());
            }
            10 => {
                // Fastscan: the reset request or one step comparing some bits.
                d[0] = 0x51;
                let bits = if b.one_in(3) { 0x80 } else { b.u8() % 32 };
                let mask = if bits >= 32 { 0 } else { u32::MAX << bits };
                d[1..5].copy_from_slice(&(value & mask).to_le_bytes());
                d[5] = bits;
                d[6] = part as u8;
                d[7] = b.u8() % 4;
            }
            _ => {
                d[0] = 0x4C + b.u8() % 5;
                d[1] = b.u8();
            }
        }
        Frame::std(0x7E5, &d)
    }
}

/// What the harness has done, for the report.
#[derive(Clone, Copy, Default, Debug)]
pub struct Stats {
    /// Inputs handled (frames, polls, stores, events, samples, power cycles).
    pub inputs: u64,
    /// Frames the node received.
    pub frames_in: u64,
    /// Frames the node sent.
    pub frames_out: u64,
    /// SDO requests answered.
    pub sdo_answers: u64,
    /// SDO transfers aborted by the server's timeout.
    pub sdo_timeouts: u64,
    /// Stores carried out on the flash.
    pub stores: u64,
    /// Power cycles (each checks the image against the saves).
    pub power_cycles: u64,
    /// Times the node was seen in LSS configuration.
    pub lss_configuration: u64,
    /// Segmented transfers completed.
    pub segmented_done: u64,
}

/// The SDO server as the checker sees it from outside.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum SdoModel {
    Idle,
    /// A transfer is open; the client's last request came at `since`.
    Open {
        since: Instant,
        download: Option<(u16, u8)>,
    },
}

/// Who asked for a pending store.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum StoreOrigin {
    Sdo,
    Lss,
    /// The AP10T's key menu (node-ID, baud rate, factory reset, auto-ID adopted).
    Panel,
}

/// A stored value as the checker expects the next power-on to find it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Expected {
    /// At its default (so it follows the node-ID the image boots with).
    Default,
    Value(u32),
}

/// A node of one kind, its parameter flash, a virtual clock and the checker's model.
pub struct Rig {
    kind: Kind,
    wrap: Wrap,
    node: Box<dyn Subject>,
    flash: ParamFlash<RamFlash>,
    now: Instant,
    client: Client,
    stores: Vec<(GroupMask, StoreOrigin)>,
    sdo: SdoModel,
    /// Bytes of the open segmented download.
    download: Vec<u8>,
    deferred: bool,
    expected: HashMap<(u16, u8), Expected>,
    /// The node detected the bit rate (listened only) before the current input.
    listening: bool,
    /// An AP10T auto-ID write (5F0Ah.02) waits for the key; its answer comes later.
    auto_id: bool,
    /// Keys were pressed on the AP10T since its power-on (a menu factory reset may follow).
    keyed: bool,
    /// Statistics.
    pub stats: Stats,
}

/// Wraps every node the rig boots (the checker's own tests wrap a node in a faulty shell to
/// see that each invariant catches its fault).
pub type Wrap = fn(Box<dyn Subject>) -> Box<dyn Subject>;

/// A broken invariant: what, after which input.
#[derive(Clone, Debug)]
pub struct Violation(pub String);

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        if !$cond {
            return Err(Violation(format!($($arg)*)));
        }
    };
}

/// Is `e` a user-stored entry (1010h groups) and does a store of `mask` write it?
fn selected(e: &Entry, mask: GroupMask) -> bool {
    let user = matches!(e.group, Group::Comm | Group::App | Group::Manuf);
    // LSS store configuration keeps the pending node-ID and bit rate, the AP10T's Auto-ID and
    // menu `ID` the node-ID alone, its `KBAUD` the bit rate alone.
    let (id, rate) = (GroupMask::LSS.0 | GroupMask::NODE_ID.0, GroupMask::LSS.0 | GroupMask::BITRATE.0);
    let pending = match e.hook {
        Hook::Core(od_core::od::CoreHook::PendingNodeId) => mask.0 & id != 0,
        Hook::Core(od_core::od::CoreHook::PendingBitrate) => mask.0 & rate != 0,
        _ => false,
    };
    (user && mask.contains(e.group)) || pending
}

/// The identifiers a node may send on now, and in which NMT states.
#[derive(Clone, Debug)]
struct Owned {
    node_id: u8,
    configured: bool,
    lss: bool,
    emcy: Option<CanId>,
    tpdos: Vec<CanId>,
    /// The valid RPDO1 and RPDO2 COB-IDs (the AP10T answers remote frames on them).
    rpdos: Vec<CanId>,
    nmt: NmtState,
}

impl Owned {
    fn of(node: &dyn Subject) -> Owned {
        let core = node.core();
        let configured = core.configured();
        let emcy = core.od.value(0x1014, 0).filter(|v| v & 0x8000_0000 == 0).map(CanId::from_cob_id);
        let mut tpdos = Vec::new();
        for n in 0..4u16 {
            if let Some(v) = core.od.value(0x1800 + n, 1) {
                if v & 0x8000_0000 == 0 {
                    tpdos.push(CanId::from_cob_id(v));
                }
            }
        }
        let rpdos = (0..2u16)
            .filter_map(|n| core.od.value(0x1400 + n, 1))
            .filter(|v| v & 0x8000_0000 == 0)
            .map(CanId::from_cob_id)
            .collect();
        Owned {
            node_id: core.node_id,
            configured,
            lss: node.lss().enabled(),
            emcy,
            tpdos,
            rpdos,
            nmt: node.nmt_state(),
        }
    }

    /// Is the node allowed to send `f` in this configuration?
    fn allows(&self, f: &Frame) -> bool {
        if f.rtr || f.len > 8 {
            return false;
        }
        if self.lss && f.id == CanId::Std(0x7E4) {
            return f.len == 8;
        }
        if !self.configured {
            return false;
        }
        let id = self.node_id as u16;
        let op = self.nmt == NmtState::Operational;
        let talk = matches!(self.nmt, NmtState::PreOperational | NmtState::Operational);
        if f.id == CanId::Std(0x580 + id) {
            return talk && f.len == 8;
        }
        if f.id == CanId::Std(0x700 + id) {
            return f.len == 1;
        }
        if Some(f.id) == self.emcy && f.len == 8 && talk {
            return true;
        }
        op && self.tpdos.contains(&f.id)
    }
}

impl Rig {
    /// A node of `kind` on a flash that the production line programmed with `node_id` (as LSS
    /// stores it; `None`: blank flash, the default node-ID), powered on.
    pub fn new(kind: Kind, node_id: Option<u8>) -> Rig {
        Rig::wrapped(kind, node_id, |n| n)
    }

    /// [`Rig::new`] with every node wrapped by `wrap`.
    pub fn wrapped(kind: Kind, node_id: Option<u8>, wrap: Wrap) -> Rig {
        let table = kind.table();
        let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(table));
        if let Some(id) = node_id {
            let mut image = Image::new();
            if let Some(e) = table.iter().find(|e| e.hook == Hook::Core(od_core::od::CoreHook::PendingNodeId)) {
                image.set(Record::of(e, id as u32)).expect("one record");
                flash.write(&image).expect("blank flash");
            }
        }
        let loaded = flash.load();
        let node = wrap(kind.boot(&loaded));
        let mut rig = Rig {
            kind,
            wrap,
            node,
            flash,
            now: Instant::ZERO,
            client: Client::new(table),
            stores: Vec::new(),
            sdo: SdoModel::Idle,
            download: Vec::new(),
            deferred: false,
            expected: HashMap::new(),
            listening: false,
            auto_id: false,
            keyed: false,
            stats: Stats::default(),
        };
        rig.expect_current(GroupMask(GroupMask::ALL.0 | GroupMask::LSS.0));
        rig.client.observe(rig.node.core());
        rig
    }

    /// The node, taken out of the rig.
    pub fn into_node(self) -> Box<dyn Subject> {
        self.node
    }

    /// The device kind.
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// The node.
    pub fn node(&self) -> &dyn Subject {
        self.node.as_ref()
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// The flash (to corrupt or inspect it).
    pub fn flash(&mut self) -> &mut ParamFlash<RamFlash> {
        &mut self.flash
    }

    /// Decodes the next action from `b` for this node.
    pub fn decode(&mut self, b: &mut Bytes) -> Option<Action> {
        self.client.observe(self.node.core());
        self.client.decode(b)
    }

    /// Runs every action `data` decodes to, checking after each input.
    pub fn run_bytes(&mut self, data: &[u8]) -> Result<(), Violation> {
        let mut b = Bytes::new(data);
        let mut n = 0;
        while let Some(a) = self.decode(&mut b) {
            self.apply(a).map_err(|v| Violation(format!("action {n} {a:?}: {v}")))?;
            n += 1;
        }
        self.settle()
    }

    /// Records the current values of the entries a store of `mask` writes as what the next
    /// power-on must find.
    fn expect_current(&mut self, mask: GroupMask) {
        let core = self.node.core();
        for (pos, e) in core.od.table().iter().enumerate() {
            if selected(e, mask) {
                let v = core.od.get(pos);
                let x = if v == core.od.default_of(e, core.node_id) { Expected::Default } else { Expected::Value(v) };
                self.expected.insert((e.index, e.sub), x);
            }
        }
    }

    /// Applies one action and checks every invariant after each input it makes.
    pub fn apply(&mut self, action: Action) -> Result<(), Violation> {
        match action {
            Action::Frame(f) => {
                self.stats.frames_in += 1;
                self.input(Input::Frame(f))
            }
            Action::Advance(us) => {
                let until = self.now.add_micros(us);
                let mut polls = 0;
                loop {
                    match self.node.next_deadline() {
                        Some(t) if t <= until && polls < MAX_POLLS_PER_ADVANCE => {
                            self.now = self.now.max(t);
                            self.input(Input::Poll)?;
                            polls += 1;
                        }
                        _ => break,
                    }
                }
                self.now = until;
                self.input(Input::Poll)
            }
            Action::LatePoll(us) => {
                self.now = self.now.add_micros(us);
                self.input(Input::Poll)
            }
            Action::StoreDone(ok) => {
                if self.stores.is_empty() {
                    return Ok(());
                }
                let (mask, origin) = self.stores.remove(0);
                self.input(Input::StoreDone { mask, origin, ok })
            }
            Action::Bus(e) => self.input(Input::Bus(e)),
            Action::Sample(raw) => self.input(Input::Sample(raw)),
            Action::PowerCycle => self.power_cycle(),
        }
    }

    /// Ends a run: completes pending stores, lets every timeout pass, and checks that the node
    /// still answers: an SDO read of 1000h (if it serves SDO) and, after NMT Reset Node, its
    /// boot-up; finally a power cycle checks the stored image.
    pub fn settle(&mut self) -> Result<(), Violation> {
        while !self.stores.is_empty() {
            self.apply(Action::StoreDone(true))?;
        }
        self.apply(Action::Advance(SDO_TIMEOUT_US + 100_000))?;
        ensure!(self.sdo == SdoModel::Idle, "SDO transfer still open after its timeout");
        let core = self.node.core();
        if core.configured() && !self.node.lss().switching() {
            let id = core.node_id;
            self.apply(Action::Frame(Frame::std(0, &[0x81, id])))?;
            self.apply(Action::Advance(0))?;
            let core = self.node.core();
            if !core.configured() {
                // The reset activated a pending node-ID FFh (LSS "unconfigured"): LSS only.
                return self.power_cycle();
            }
            ensure!(self.node.nmt_state() == NmtState::PreOperational, "no boot-up after reset node");
            let answer = self.sdo_answer(crate::encoder::upload_request(0x1000, 0))?;
            let want = self.node.core().od.value(0x1000, 0).unwrap_or(0).to_le_bytes();
            ensure!(
                answer == [0x43, 0x00, 0x10, 0x00, want[0], want[1], want[2], want[3]],
                "1000h read after the run answered {answer:02X?}"
            );
        }
        self.power_cycle()
    }

    /// Sends an SDO request and returns the answer (checked like any input).
    pub fn sdo_answer(&mut self, req: [u8; 8]) -> Result<[u8; 8], Violation> {
        let id = self.node.core().node_id as u16;
        let f = Frame::std(0x600 + id, &req);
        let sent = self.input_collect(Input::Frame(f))?;
        let a =
            sent.iter().find(|f| f.id == CanId::Std(0x580 + id)).ok_or_else(|| Violation("no SDO answer".into()))?;
        let mut out = [0u8; 8];
        out.copy_from_slice(a.payload());
        Ok(out)
    }

    fn power_cycle(&mut self) -> Result<(), Violation> {
        self.stats.power_cycles += 1;
        self.stats.inputs += 1;
        self.flash.flash().power_on();
        let loaded = self.flash.load();
        ensure!(loaded != Loaded::Invalid, "the flash holds no valid image after saves only");
        self.node = (self.wrap)(self.kind.boot(&loaded));
        self.stores.clear();
        self.sdo = SdoModel::Idle;
        self.deferred = false;
        self.auto_id = false;
        self.keyed = false;
        let core = self.node.core();
        for (pos, e) in core.od.table().iter().enumerate() {
            if let Some(x) = self.expected.get(&(e.index, e.sub)) {
                let want = match *x {
                    Expected::Default => core.od.default_of(e, core.node_id),
                    Expected::Value(v) => v,
                };
                ensure!(
                    core.od.get(pos) == want,
                    "power-on: {:04X}h.{:02X} = {:#X}, the saves stored {want:#X}",
                    e.index,
                    e.sub,
                    core.od.get(pos)
                );
            }
        }
        self.check_values()?;
        // The power-on's first poll sends the boot-up.
        self.apply(Action::Advance(0))
    }

    fn input(&mut self, input: Input) -> Result<(), Violation> {
        self.input_collect(input).map(|_| ())
    }

    /// Feeds one input, carries out its outputs and checks everything; returns the frames sent.
    fn input_collect(&mut self, input: Input) -> Result<Vec<Frame>, Violation> {
        self.stats.inputs += 1;
        let before = Owned::of(&*self.node);
        let lss_before = self.node.lss().state();
        let switching_before = self.node.lss().switching();
        // While it detects the bit rate, a node takes any frame only as proof of the rate: it
        // ends the detection (the boot-up follows at the next poll) and is no service, so it
        // is checked as an input that serves nothing (a receive overrun).
        let listening = self.node.listen_only();
        self.listening = listening;
        let now = self.now;
        match input {
            Input::Frame(f) => self.node.on_frame(&f, now),
            Input::Poll => self.node.poll(now),
            Input::StoreDone { mask, ok, .. } => {
                let ok = ok && self.flash.save(self.node.core(), mask).is_ok();
                if ok {
                    self.stats.stores += 1;
                    self.expect_current(mask);
                }
                self.node.store_done(ok, now);
            }
            Input::Bus(e) => self.node.on_bus_event(e, now),
            Input::Sample(raw) => {
                self.keyed |= self.kind == Kind::Ap10t;
                self.node.sample(raw, now)
            }
        }
        let mut sent = Vec::new();
        let mut stores = Vec::new();
        while let Some(out) = self.node.next_output() {
            match out {
                Output::Frame(f) => sent.push(f),
                Output::Store(mask) => stores.push(mask),
                Output::SetBitrate(_) => {}
            }
        }
        self.stats.frames_out += sent.len() as u64;
        let after = Owned::of(&*self.node);
        if self.node.lss().state() == od_core::lss::LssState::Configuration {
            self.stats.lss_configuration += 1;
        }
        let seen = match input {
            Input::Frame(_) if listening => Input::Bus(BusEvent::RxOverrun),
            other => other,
        };
        self.check(&seen, &before, &after, lss_before, switching_before, &sent, &stores)
            .map_err(|v| Violation(format!("at {} us, {input:?}: {v}; sent {sent:02X?}", now.as_micros())))?;
        Ok(sent)
    }

    #[allow(clippy::too_many_arguments)]
    fn check(
        &mut self,
        input: &Input,
        before: &Owned,
        after: &Owned,
        lss_before: od_core::lss::LssState,
        switching_before: bool,
        sent: &[Frame],
        stores: &[GroupMask],
    ) -> Result<(), Violation> {
        // Nothing lost: checked first, since a lost output breaks what the checks below see.
        check_outbox(self.node.core())?;
        // Identifiers and states.
        let rtr_answers = sent.iter().filter(|f| self.rtr_answer(input, before, f)).count();
        ensure!(rtr_answers <= 1, "{rtr_answers} answers to one remote frame");
        for f in sent {
            ensure!(
                before.allows(f) || after.allows(f) || self.rtr_answer(input, before, f),
                "sent {f:?}, not an identifier it owns in this state"
            );
            if before.configured && f.id == CanId::Std(0x700 + before.node_id as u16)
                || after.configured && f.id == CanId::Std(0x700 + after.node_id as u16)
            {
                let code = f.data[0] & 0x7F;
                ensure!(
                    code == 0 || code == before.nmt.code() || code == after.nmt.code(),
                    "error control frame {f:?} in state {:?}/{:?}",
                    before.nmt,
                    after.nmt
                );
            }
        }
        ensure!(after.node_id == 0xFF || (1..=127).contains(&after.node_id), "node-ID {}", after.node_id);
        // NMT transitions.
        let lss_frame = matches!(input, Input::Frame(f) if f.id == CanId::Std(0x7E5));
        match input {
            Input::Frame(f) if f.id == CanId::Std(0) => {
                let nmt = od_core::wire::nmt::NmtRequest::parse(f.payload());
                let handled = before.configured && before.nmt != NmtState::Initialising;
                let want = match nmt {
                    Some(r) if handled && r.addresses(before.node_id) => match r.command.cs() {
                        0x01 => NmtState::Operational,
                        0x02 => NmtState::Stopped,
                        0x80 => NmtState::PreOperational,
                        _ => NmtState::Initialising,
                    },
                    _ => before.nmt,
                };
                ensure!(after.nmt == want, "NMT {:?} -> {:?}, expected {want:?}", before.nmt, after.nmt);
            }
            Input::Frame(_) if lss_frame => {
                ensure!(
                    after.nmt == before.nmt || after.nmt == NmtState::Initialising,
                    "LSS frame moved NMT {:?} -> {:?}",
                    before.nmt,
                    after.nmt
                );
            }
            Input::Poll => {
                let booted = after.configured
                    && after.nmt == NmtState::PreOperational
                    && sent.iter().any(|f| f.id == CanId::Std(0x700 + after.node_id as u16) && f.payload() == [0]);
                // The AP10T's external heartbeat (5F09h.01 ms, not 0) ran out in OPERATIONAL:
                // PRE-OPERATIONAL (D-AP-19).
                let heartbeat_lost = self.kind == Kind::Ap10t
                    && before.nmt == NmtState::Operational
                    && after.nmt == NmtState::PreOperational
                    && self.node.core().od.value(0x5F09, 1).is_some_and(|ms| ms != 0);
                ensure!(
                    after.nmt == before.nmt
                        || booted
                        || heartbeat_lost
                        || (switching_before && after.nmt == NmtState::Initialising),
                    "poll moved NMT {:?} -> {:?} without a boot-up",
                    before.nmt,
                    after.nmt
                );
                ensure!(
                    !(after.configured
                        && after.nmt == NmtState::Initialising
                        && !self.node.lss().switching()
                        && !self.listening
                        && !self.node.listen_only()),
                    "still initialising after a poll"
                );
                if let Some(t) = self.node.next_deadline() {
                    ensure!(t > self.now, "deadline {t:?} still due after the poll at {:?}", self.now);
                }
            }
            _ => ensure!(after.nmt == before.nmt, "NMT {:?} -> {:?} on a non-NMT input", before.nmt, after.nmt),
        }
        // LSS switch to waiting after configure node-ID resets an unconfigured node's
        // communication (CiA 305): INITIALISATION before and after.
        let reset = after.nmt == NmtState::Initialising && (before.nmt != NmtState::Initialising || lss_frame)
            || sent.iter().any(|f| f.id == CanId::Std(0x700 + after.node_id as u16) && f.payload() == [0]);
        ensure!(
            after.node_id == before.node_id || reset,
            "node-ID {} -> {} without a reset",
            before.node_id,
            after.node_id
        );
        // LSS.
        let lss_after = self.node.lss().state();
        ensure!(lss_after == lss_before || lss_frame || reset, "LSS {lss_before:?} -> {lss_after:?} on {input:?}");
        let lss_answers = sent.iter().filter(|f| f.id == CanId::Std(0x7E4)).count();
        let lss_store_done = matches!(input, Input::StoreDone { origin: StoreOrigin::Lss, .. });
        ensure!(
            lss_answers == 0 || ((lss_frame || lss_store_done) && lss_answers == 1),
            "{lss_answers} LSS answers to {input:?}"
        );
        // Stores: only a valid 1010h save or LSS store configuration asks for one.
        ensure!(stores.len() <= 1, "{} stores for one input", stores.len());
        if let Some(&mask) = stores.first() {
            let origin = self.store_origin(input, lss_before, mask)?;
            self.stores.push((mask, origin));
        }
        // SDO.
        self.check_sdo(input, before, after, sent, !stores.is_empty())?;
        self.check_values()
    }

    /// Is `f` the AP10T's answer to a remote frame on RPDO1 or RPDO2 (`input`), which it
    /// sends in OPERATIONAL on the remote frame's own identifier with 8 bytes: the set point
    /// read back (manual 4.3, "via RTR at RPDO1 and RPDO2 the setpoints can be read"; D-PDO-7,
    /// D-AP-22)?
    fn rtr_answer(&self, input: &Input, before: &Owned, f: &Frame) -> bool {
        let Input::Frame(rtr) = input else { return false };
        self.kind == Kind::Ap10t
            && rtr.rtr
            && rtr.id == f.id
            && !f.rtr
            && f.len == 8
            && before.configured
            && before.nmt == NmtState::Operational
            && before.rpdos.contains(&f.id)
    }

    /// The request behind a store of `mask` at `input`, or the violation.
    fn store_origin(
        &self,
        input: &Input,
        lss_before: od_core::lss::LssState,
        mask: GroupMask,
    ) -> Result<StoreOrigin, Violation> {
        let bus = self.bus_store_origin(input, lss_before, mask);
        if bus.is_ok() {
            return bus;
        }
        // The AP10T's menu keeps a node-ID or baud rate at once; a menu factory reset stores
        // everything at the reset that follows the key (manual Table 3, D-AP-16).
        if self.kind == Kind::Ap10t {
            match input {
                Input::Sample(_) if mask == GroupMask::NODE_ID || mask == GroupMask::BITRATE => {
                    return Ok(StoreOrigin::Panel)
                }
                Input::Poll | Input::Frame(_) if mask == GroupMask::ALL && self.keyed => return Ok(StoreOrigin::Panel),
                _ => {}
            }
        }
        bus
    }

    /// A store asked for by a request on the bus: a 1010h save or LSS store configuration.
    fn bus_store_origin(
        &self,
        input: &Input,
        lss_before: od_core::lss::LssState,
        mask: GroupMask,
    ) -> Result<StoreOrigin, Violation> {
        let Input::Frame(f) = input else {
            return Err(Violation(format!("store {mask:?} without a request")));
        };
        if f.id == CanId::Std(0x7E5) {
            ensure!(
                f.data[0] == 0x17 && lss_before == od_core::lss::LssState::Configuration && mask == GroupMask::LSS,
                "store {mask:?} on LSS {f:?} in {lss_before:?}"
            );
            return Ok(StoreOrigin::Lss);
        }
        sdo_save(f.payload(), self.sdo, &self.download, mask).map_err(|v| Violation(format!("{v} ({f:?})")))?;
        Ok(StoreOrigin::Sdo)
    }

    fn check_sdo(
        &mut self,
        input: &Input,
        before: &Owned,
        after: &Owned,
        sent: &[Frame],
        stored: bool,
    ) -> Result<(), Violation> {
        let answers: Vec<[u8; 8]> = sent
            .iter()
            .filter(|f| before.configured && f.id == CanId::Std(0x580 + before.node_id as u16))
            .map(|f| f.data)
            .collect();
        ensure!(answers.len() <= 1, "{} SDO answers to one input", answers.len());
        let answer = answers.first().copied();
        if answer.is_some() {
            self.stats.sdo_answers += 1;
        }
        match input {
            Input::Frame(f)
                if before.configured
                    && f.id == CanId::Std(0x600 + before.node_id as u16)
                    && !f.rtr
                    && matches!(before.nmt, NmtState::PreOperational | NmtState::Operational) =>
            {
                if f.len != 8 {
                    ensure!(answer.is_none(), "answer to a {}-byte SDO request", f.len);
                    return Ok(());
                }
                let req = f.data;
                let ccs = req[0] >> 5;
                let Some(a) = answer else {
                    // The AP10T's auto-ID: a write to 5F0Ah.02 at the factory node-ID 7Dh is
                    // answered when the key is pressed (manual 4.6.2).
                    if self.kind == Kind::Ap10t
                        && before.node_id == 0x7D
                        && req[0] & 0xE3 == 0x23
                        && req[1..4] == [0x0A, 0x5F, 0x02]
                    {
                        self.auto_id = true;
                        self.sdo = SdoModel::Idle;
                        return Ok(());
                    }
                    // No answer: a client abort, or a save whose answer waits for the store.
                    ensure!(ccs == 4 || stored, "SDO request {req:02X?} unanswered");
                    if stored {
                        self.deferred = true;
                        if ccs == 0 {
                            self.stats.segmented_done += 1;
                        }
                    }
                    self.sdo = SdoModel::Idle;
                    return Ok(());
                };
                let (open, done) = sdo_answer_fits(&req, &a)?;
                self.stats.segmented_done += done as u64;
                if open {
                    let download = match (ccs, self.sdo) {
                        (1, _) => {
                            self.download.clear();
                            Some((u16::from_le_bytes([req[1], req[2]]), req[3]))
                        }
                        (0, SdoModel::Open { download, .. }) => {
                            let n = 7 - ((req[0] >> 1) & 7) as usize;
                            self.download.extend_from_slice(&req[1..1 + n]);
                            download
                        }
                        _ => None,
                    };
                    self.sdo = SdoModel::Open { since: self.now, download };
                } else {
                    self.sdo = SdoModel::Idle;
                }
            }
            Input::Poll | Input::Sample(_) if self.auto_id && answer.is_some() => {
                let a = answer.unwrap_or_default();
                ensure!(a == [0x60, 0x0A, 0x5F, 0x02, 0, 0, 0, 0], "answer {a:02X?} to the auto-ID write");
                self.auto_id = false;
            }
            Input::Poll => {
                if let Some(a) = answer {
                    let SdoModel::Open { since, .. } = self.sdo else {
                        return Err(Violation(format!("SDO frame {a:02X?} from a poll with no transfer open")));
                    };
                    ensure!(a[0] == 0x80 && a[4..] == [0x00, 0x00, 0x04, 0x05], "poll sent SDO {a:02X?}");
                    ensure!(self.now.micros_since(since) >= SDO_TIMEOUT_US, "timeout abort too early");
                    self.stats.sdo_timeouts += 1;
                    self.sdo = SdoModel::Idle;
                }
                if let SdoModel::Open { since, .. } = self.sdo {
                    let serving = after.configured
                        && !self.node.lss().switching()
                        && matches!(after.nmt, NmtState::PreOperational | NmtState::Operational);
                    ensure!(
                        !(serving && self.now.micros_since(since) >= SDO_TIMEOUT_US),
                        "transfer open since {} us not aborted at {} us",
                        since.as_micros(),
                        self.now.as_micros()
                    );
                }
            }
            // The Auto-ID key asks for the node-ID's store and for the waiting answer, which
            // goes out at the next poll (`60 0A 5F 02 ...`) or, if the store is done first (the
            // firmware carries out a store before it polls), when it is done: `60 0A 5F 02 ...`
            // or, if the flash failed, 08000020h "cannot store".
            Input::StoreDone { origin: StoreOrigin::Panel, .. } if self.auto_id && answer.is_some() => {
                let a = answer.unwrap_or_default();
                ensure!(
                    a == [0x60, 0x0A, 0x5F, 0x02, 0, 0, 0, 0] || a == [0x80, 0x0A, 0x5F, 0x02, 0x20, 0x00, 0x00, 0x08],
                    "answer {a:02X?} to the auto-ID write when its store is done"
                );
                self.auto_id = false;
            }
            Input::StoreDone { origin, .. } => {
                if let Some(a) = answer {
                    ensure!(*origin == StoreOrigin::Sdo && self.deferred, "SDO answer {a:02X?} to no pending save");
                    ensure!(
                        a == [0x60, 0x10, 0x10, a[3], 0, 0, 0, 0]
                            || (a[0] & 0xEF == 0x20 && a[1..] == [0; 7])
                            || (a[0] == 0x80 && a[1..3] == [0x10, 0x10]),
                        "answer to a save: {a:02X?}"
                    );
                    self.deferred = false;
                }
            }
            _ => ensure!(answer.is_none(), "SDO frame {:02X?} on {input:?}", answer),
        }
        // The server drops a transfer and a waiting save on NMT stop, on every reset and
        // when an LSS bit-rate switch ends.
        let nmt_reset = matches!(input, Input::Frame(f) if f.id == CanId::Std(0) && od_core::wire::nmt::NmtRequest::parse(f.payload()).is_some_and(|r| {
            before.configured && before.nmt != NmtState::Initialising && r.addresses(before.node_id)
                && matches!(r.command.cs(), 0x02 | 0x81 | 0x82)
        }));
        // The AP10T's external-heartbeat timeout (D-AP-19) only enters PRE-OPERATIONAL, as NMT
        // 80h does: the SDO server keeps a transfer and a waiting save through it.
        let to_pre_operational = before.nmt == NmtState::Operational && after.nmt == NmtState::PreOperational;
        let reinit = after.nmt == NmtState::Initialising && before.nmt != NmtState::Initialising
            || matches!(input, Input::Poll) && after.nmt != before.nmt && !to_pre_operational;
        if nmt_reset || reinit {
            self.sdo = SdoModel::Idle;
            self.deferred = false;
            self.auto_id = false;
        }
        if let Input::StoreDone { origin: StoreOrigin::Sdo, .. } = input {
            self.deferred = false;
        }
        Ok(())
    }

    /// Every value within its type and declared limits.
    fn check_values(&self) -> Result<(), Violation> {
        check_values(self.node.core())
    }
}

/// The store of `mask` an SDO request `d` asked for: an expedited write of "save" to 1010h sub
/// 1..4 with the matching group mask, or the last segment of a segmented download of "save"
/// that the server has open (`sdo`, with the bytes so far in `download`).
fn sdo_save(d: &[u8], sdo: SdoModel, download: &[u8], mask: GroupMask) -> Result<(), Violation> {
    ensure!(d.len() == 8, "store on a short frame");
    let (index, sub, data): (u16, u8, Vec<u8>) = if d[0] >> 5 == 1 && d[0] & 2 != 0 {
        let n = if d[0] & 1 != 0 { 4 - ((d[0] >> 2) & 3) as usize } else { 4 };
        (u16::from_le_bytes([d[1], d[2]]), d[3], d[4..4 + n].to_vec())
    } else if let SdoModel::Open { download: Some((i, s)), .. } = sdo {
        let n = 7 - ((d[0] >> 1) & 7) as usize;
        let mut all = download.to_vec();
        all.extend_from_slice(&d[1..1 + n]);
        (i, s, all)
    } else {
        return Err(Violation(format!("store {mask:?} on {d:02X?}, no download open")));
    };
    ensure!(
        index == 0x1010 && data == b"save" && GroupMask::from_subindex(sub) == Some(mask),
        "store {mask:?} on a write of {data:02X?} to {index:04X}h.{sub:02X}"
    );
    Ok(())
}

/// Does the SDO server's answer `a` fit the client's request `req`? Returns whether the
/// transfer stays open after it, and whether it completed a segmented download.
fn sdo_answer_fits(req: &[u8; 8], a: &[u8; 8]) -> Result<(bool, bool), Violation> {
    let ccs = req[0] >> 5;
    ensure!(ccs != 4, "answer {a:02X?} to a client abort");
    let mut done = false;
    let open = match (ccs, a[0]) {
        (_, 0x80) => false,
        (2, 0x41) => true,
        (2, s) if s & 0xF3 == 0x43 => false,
        (1, 0x60) => req[0] & 2 == 0,
        (3, s) if s >> 5 == 0 => s & 1 == 0,
        (0, s) if s >> 5 == 1 => {
            done = req[0] & 1 != 0;
            req[0] & 1 == 0
        }
        _ => return Err(Violation(format!("answer {a:02X?} does not fit request {req:02X?}"))),
    };
    if a[0] == 0x80 && (ccs == 1 || ccs == 2) {
        ensure!(a[1..4] == req[1..4], "abort {a:02X?} names another object than {req:02X?}");
    }
    Ok((open, done))
}

/// The node's outbox never dropped an output: the rig drains it after every call, as every
/// shell does (D-ARCH-3), and the outbox holds the worst single call's outputs.
pub fn check_outbox(core: &Core) -> Result<(), Violation> {
    let dropped = core.out.dropped();
    ensure!(dropped == 0, "the outbox dropped {dropped} outputs although it is drained after every call");
    Ok(())
}

/// Nothing dropped from `core`'s outbox ([`check_outbox`]) and every value of its dictionary
/// within its type and declared limits.
pub fn check_values(core: &Core) -> Result<(), Violation> {
    check_outbox(core)?;
    let od = &core.od;
    for (pos, e) in od.table().iter().enumerate() {
        let v = od.get(pos);
        let fits = match e.dtype {
            DataType::Boolean => v <= 1,
            DataType::Integer8 | DataType::Unsigned8 => v <= 0xFF,
            DataType::Integer16 | DataType::Unsigned16 => v <= 0xFFFF,
            DataType::VisibleString => v == 0,
            _ => true,
        };
        ensure!(fits, "{:04X}h.{:02X} = {v:#X} does not fit {:?}", e.index, e.sub, e.dtype);
        // D-LSS-5: LSS may set the pending node-ID to FFh ("unconfigured").
        let unconfigured = e.hook == Hook::Core(od_core::od::CoreHook::PendingNodeId) && v == 0xFF;
        if let Some((lo, hi)) = e.limits().filter(|_| !unconfigured) {
            let x = e.dtype.to_i64(v);
            ensure!(lo <= x && x <= hi, "{:04X}h.{:02X} = {x} outside {lo}..={hi}", e.index, e.sub);
        }
    }
    Ok(())
}

/// One call into the node.
#[derive(Clone, Copy, Debug)]
enum Input {
    Frame(Frame),
    Poll,
    StoreDone { mask: GroupMask, origin: StoreOrigin, ok: bool },
    Bus(BusEvent),
    Sample(Result<u32, SensorFault>),
}

/// A node of `kind` powered on from a flash the production line programmed with `node_id`
/// (as LSS stores it), before its first poll.
pub fn boot_with_id(kind: Kind, node_id: u8) -> Box<dyn Subject> {
    Rig::new(kind, Some(node_id)).into_node()
}

/// Runs `data` against a node of `kinds[data[0] % len]` (node-ID from `data[1]`) and panics
/// with the violation: the body of every fuzz target and of the proptest.
pub fn run_case(data: &[u8]) -> Stats {
    let kind = KINDS[data.first().copied().unwrap_or(0) as usize % KINDS.len()];
    run_kind(kind, data.get(1..).unwrap_or(&[]))
}

/// Runs `data` against a node of `kind`: `data[0]` picks the node-ID the flash holds (0: a
/// blank flash), the rest are actions. Panics with the violation.
pub fn run_kind(kind: Kind, data: &[u8]) -> Stats {
    let node_id = match data.first().copied().unwrap_or(0) {
        0 => None,
        b => Some(1 + b % 127),
    };
    let mut rig = Rig::new(kind, node_id);
    if let Err(v) = rig.run_bytes(data.get(1..).unwrap_or(&[])) {
        panic!("{}: {v}", kind.name());
    }
    rig.stats
}

/// The storage loader fed any flash content: `data[0]` picks the kind, the rest is what the
/// parameter pages hold. Loading never panics; a node boots from whatever it found with every
/// value within its limits; a save over it works (unless the pages hold an image it cannot
/// verify) and the next power-on finds exactly the saved values. Panics with the violation.
pub fn run_flash(data: &[u8]) {
    let kind = KINDS[data.first().copied().unwrap_or(0) as usize % KINDS.len()];
    let mut bytes = data.get(1..).unwrap_or(&[]).to_vec();
    bytes.truncate(REGION.pages as usize * crate::flash::PAGE);
    let table = kind.table();
    let mut flash = ParamFlash::new(RamFlash::from_bytes(bytes), REGION, identity(table));
    let loaded = flash.load();
    let node = kind.boot(&loaded);
    if let Err(v) = check_values(node.core()) {
        panic!("{}: booted from {loaded:?}: {v}", kind.name());
    }
    if flash.save(node.core(), GroupMask::ALL).is_err() {
        return;
    }
    let again = flash.load();
    let Loaded::Image(_) = again else {
        panic!("{}: after a save the flash holds {again:?}", kind.name());
    };
    let second = kind.boot(&again);
    for (pos, e) in table.iter().enumerate() {
        if selected(e, GroupMask::ALL) {
            let (a, b) = (node.core().od.get(pos), second.core().od.get(pos));
            assert!(a == b, "{}: {:04X}h.{:02X} saved {a:#X}, loaded {b:#X}", kind.name(), e.index, e.sub);
        }
    }
}

/// The socketcand message parser fed any bytes: splitting keeps at most an incomplete message
/// of bounded size, every parsed `send` is a valid frame that round-trips through the client's
/// formatting, and every error answer is one well-formed message. Panics with the violation.
pub fn run_socketcand(data: &[u8]) {
    use crate::sim::socketcand::{
        frame_message, parse, send_message, split_messages, Refused, Request, UNKNOWN_COMMAND,
    };
    let mut buf = String::new();
    for chunk in data.split(|&b| b == 0) {
        buf.push_str(&String::from_utf8_lossy(chunk));
        for msg in split_messages(&mut buf) {
            let text = match msg.map(|m| parse(&m)) {
                Ok(Ok(Request::Send(f))) => {
                    assert!(f.len <= 8 && (!f.rtr || f.data == [0; 8]), "parsed {f:?}");
                    match f.id {
                        CanId::Std(id) => assert!(id <= 0x7FF, "{f:?}"),
                        CanId::Ext(id) => assert!(id <= 0x1FFF_FFFF, "{f:?}"),
                    }
                    let again = parse(&send_message(&f));
                    assert_eq!(again, Ok(Request::Send(f)), "round trip of {f:?}");
                    frame_message(&f, u64::MAX)
                }
                Ok(Ok(_)) => continue,
                // socketcand drops a malformed message without an answer.
                Ok(Err(Refused::Malformed(_))) | Err(Refused::Malformed(_)) => continue,
                Ok(Err(Refused::Unknown)) | Err(Refused::Unknown) => UNKNOWN_COMMAND.to_string(),
            };
            assert!(
                text.starts_with('<') && text.ends_with('>') && text.matches(['<', '>']).count() == 2,
                "answer {text:?}"
            );
        }
        assert!(buf.is_empty() || (buf.starts_with('<') && !buf.contains('>')), "rest {buf:?}");
        assert!(buf.len() <= 256, "rest of {} bytes", buf.len());
    }
}
