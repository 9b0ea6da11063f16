//! The WV58MR, a J1939 node, under the same stress as the CANopen nodes ([`super`]): any frames
//! with any timing, and after **every** input the checker verifies:
//!
//! - no panic, nothing dropped from the outbox, every dictionary value within its type and
//!   limits ([`super::check_values`]);
//! - the stored image changes only through a valid save: an `Output::Store` comes only from a
//!   CAM21 request to the node's claimed address whose SDO payload writes "save" to 1010h sub
//!   1..4 with the matching group mask (expedited, or the last segment of a segmented
//!   download), and the next power-on finds exactly what the saves stored;
//! - the node transmits only extended data frames of 8 bytes: its Address Claimed (its own NAME,
//!   from the address it claims or, unable to claim, from the null address FEh) and, only from
//!   the address whose claim has stood 250 ms, the groups it owns (EPOS, ESPD, Proprietary B at
//!   the priorities of 3000h), EMCY (priority 1), a NACK to a Request, and CAM11 to the
//!   requester of a CAM21;
//! - the address-claim state is valid: claiming starts at the first poll, the claimed address
//!   lies in 5F0Ah.01's range, a claim becomes the source address only on the poll at least
//!   250 ms after it (and that poll must make it so), a contest for our address is won with our
//!   claim sent again when our NAME is lower and otherwise the address is given up (a new claim
//!   or Cannot Claim), and nothing else changes the state except the 3002h commands;
//! - every request gets at most one answer: a Request for a group the node owns exactly the
//!   group once the claim stood, one to our address for another group exactly one NACK, a
//!   Request for Address Claimed our claim; a CAM21 at most one CAM11 (exactly one unless it is
//!   a client abort or a save whose answer waits for the store), which fits the request; an
//!   open transfer is aborted with 05040000h once its 1 s timeout passed, never earlier.
//!
//! Inputs come from [`J1939Client::decode`]: the CANopen client's SDO requests ([`Client`])
//! carried by CAM21 from a master (or any source, to our address or another), and J1939's own
//! traffic: Requests for every group, Address Claimed contests with NAMEs just below, equal to
//! and above ours, the 3002h commands, 5F0Ah.01 and 3000h writes, any extended frame, and the
//! shared time, store, bus-event, sensor and power-cycle actions.

use std::collections::HashMap;

use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::Wv58mr;
use od_core::encoder::{Encoder, SensorFault};
use od_core::j1939::claim::{State, CONTENTION_MS};
use od_core::j1939::node::{name_of, J1939Node, EMCY_PRIORITY, PROVIDED};
use od_core::node::Output;
use od_core::od::{GroupMask, Hook};
use od_core::storage::{identity, Image, Loaded, ParamFlash, Record};
use od_core::wire::j1939::{Address, Identifier, Name, Pgn};
use od_core::{CanId, DeviceStation, Frame, Instant};

use super::{
    check_values, sdo_answer_fits, sdo_save, selected, Action, Bytes, Client, Expected, SdoModel, Violation,
    MAX_POLLS_PER_ADVANCE, REGION, SDO_TIMEOUT_US,
};
use crate::flash::RamFlash;

macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        if !$cond {
            return Err(Violation(format!($($arg)*)));
        }
    };
}

/// The master's address (the manual's examples use 00h).
pub const MASTER: u8 = 0x00;

/// The WV58MR variants the stress covers (the measuring range changes the dictionary's limits).
pub const TURNS: [Turns; 3] = [Turns::Multi12, Turns::Single, Turns::Multi4];

/// What the J1939 harness has done, for the report.
#[derive(Clone, Copy, Default, Debug)]
pub struct J1939Stats {
    /// Inputs handled.
    pub inputs: u64,
    /// Frames the node received.
    pub frames_in: u64,
    /// Frames the node sent.
    pub frames_out: u64,
    /// CAM21 requests answered by CAM11.
    pub cam_answers: u64,
    /// SDO transfers aborted by the server's timeout.
    pub sdo_timeouts: u64,
    /// Requests (PGN 59904) answered (a group, a NACK or a claim).
    pub requests_answered: u64,
    /// Contests for our address lost (a new claim or Cannot Claim followed).
    pub contests_lost: u64,
    /// Contests for our address won (our claim sent again).
    pub contests_won: u64,
    /// Inputs after which the node could claim no address.
    pub cannot_claim: u64,
    /// Claims that stood (the state became Claimed).
    pub claims_stood: u64,
    /// Stores carried out on the flash.
    pub stores: u64,
    /// Power cycles (each checks the image against the saves).
    pub power_cycles: u64,
    /// Segmented downloads completed over CAM21.
    pub segmented_done: u64,
}

/// The client of a WV58MR: the CANopen [`Client`]'s SDO requests carried by CAM21, and J1939's
/// own traffic.
pub struct J1939Client {
    sdo: Client,
    /// The rest of a crowded-bus script (every address claimed by another CA).
    script: std::collections::VecDeque<Action>,
    /// The node's NAME (from 3001h), read before each action.
    pub name: Name,
    /// The address the node claims (or claimed last, or its preferred one).
    pub address: u8,
}

/// The node-ID the CANopen client is told: its SDO requests go to 600h + this, which the
/// J1939 client carries by CAM21 instead.
const CLIENT_ID: u8 = 1;

impl J1939Client {
    fn new(sdo: Client) -> J1939Client {
        let mut sdo = sdo;
        sdo.node_id = CLIENT_ID;
        J1939Client { sdo, script: Default::default(), name: Name::from_raw(0), address: 0xEF }
    }

    /// A source address: mostly the master, sometimes another, any, or the null address.
    fn source(&self, b: &mut Bytes) -> u8 {
        match b.u8() % 8 {
            0..=4 => MASTER,
            5 => 0x21,
            6 => self.address,
            _ => b.u8(),
        }
    }

    /// A destination: mostly our address, sometimes the global one or any.
    fn destination(&self, b: &mut Bytes) -> u8 {
        match b.u8() % 8 {
            0..=4 => self.address,
            5 => 0xFF,
            6 => self.address.wrapping_add(1),
            _ => b.u8(),
        }
    }

    fn pdu1(pf: u8, da: u8, sa: u8, data: &[u8]) -> Frame {
        Frame::new(CanId::Ext(0x1800_0000 | (pf as u32) << 16 | (da as u32) << 8 | sa as u32), data)
    }

    fn cam21(&self, da: u8, sa: u8, data: &[u8]) -> Frame {
        let mut f = Self::pdu1(0x06, da, sa, data);
        if let CanId::Ext(raw) = f.id {
            f.id = CanId::Ext(raw | 0x0400_0000); // priority 7, as the manual's E1
        }
        f
    }

    /// Decodes the next action; `None` when the bytes are used up.
    pub fn decode(&mut self, b: &mut Bytes) -> Option<Action> {
        if b.is_empty() {
            return None;
        }
        if !self.script.is_empty() && !b.one_in(16) {
            return self.script.pop_front();
        }
        let op = b.u8();
        if !op.is_multiple_of(4) {
            // The CANopen client's action; its SDO requests go by CAM21.
            let (sa, da) =
                if op & 0x30 == 0x30 { (self.source(b), self.destination(b)) } else { (MASTER, self.address) };
            return Some(match self.sdo.decode(b)? {
                Action::Frame(f) if f.id == CanId::Std(0x600 + CLIENT_ID as u16) => {
                    Action::Frame(self.cam21(da, sa, f.payload()))
                }
                other => other,
            });
        }
        let sa = self.source(b);
        let da = self.destination(b);
        Some(match b.u8() % 9 {
            // A crowded bus: other CAs, with NAMEs lower than ours, claim every address of the
            // range, ours last: the node moves until none is left and it cannot claim.
            8 if b.one_in(8) => {
                let ours = self.address;
                for a in (0x80..=0xEFu8).filter(|&a| a != ours).chain([ours]) {
                    let name = self.name.raw().wrapping_sub(1 + a as u64);
                    self.script.push_back(Action::Frame(Self::pdu1(0xEE, 0xFF, a, &name.to_le_bytes())));
                }
                self.script.pop_front()?
            }
            // A Request for a group: ours, the claim, ones we do not provide, any.
            0 | 1 => {
                let pgn = match b.u8() % 9 {
                    0 => Pgn::EPOS.raw(),
                    1 => Pgn::ESPD.raw(),
                    2 => Pgn::PROPRIETARY_B.raw(),
                    3 | 4 => Pgn::ADDRESS_CLAIMED.raw(),
                    5 => Pgn::CAM11.raw(),
                    6 => Pgn::EMCY.raw(),
                    7 => Pgn::ACKNOWLEDGEMENT.raw(),
                    _ => b.u32() & 0x3FFFF,
                }
                .to_le_bytes();
                let len = if b.one_in(8) { (b.u8() % 9) as usize } else { 3 };
                let d = [pgn[0], pgn[1], pgn[2], b.u8(), b.u8(), b.u8(), b.u8(), b.u8()];
                Action::Frame(Self::pdu1(0xEA, da, sa, &d[..len]))
            }
            // Address Claimed: a contest for our address (a NAME just below ours, equal, just
            // above, any), a claim of another address, Cannot Claim.
            2 | 3 => {
                let ours = self.name.raw();
                let name = match b.u8() % 6 {
                    0 => ours.wrapping_sub(1 + b.u8() as u64),
                    1 => ours,
                    2 => ours.wrapping_add(1 + b.u8() as u64),
                    3 => ours ^ 1 << 63,
                    _ => (b.u32() as u64) << 32 | b.u32() as u64,
                };
                let src = match b.u8() % 4 {
                    0 | 1 => self.address,
                    2 => 0x80 + b.u8() % 0x70,
                    _ => sa,
                };
                let len = if b.one_in(8) { (b.u8() % 9) as usize } else { 8 };
                Action::Frame(Self::pdu1(0xEE, 0xFF, src, &name.to_le_bytes()[..len]))
            }
            // The WV58MR's own writes: 3002h commands, the address, cycle times, priorities.
            4 | 5 => {
                let (index, sub, value) = match b.u8() % 7 {
                    0 => (0x3002, 1 + b.u8() % 2, if b.one_in(4) { b.u8() as u32 } else { 1 }),
                    6 => (0x3001, 10, b.u8() as u32 % 2),
                    1 => (0x5F0A, 1, if b.one_in(4) { b.u8() as u32 } else { 0x80 + (b.u8() % 0x70) as u32 }),
                    2 => (0x3000, 1 + b.u8() % 3, [0, 1, 5, 10, 50, 100, 1000][b.u8() as usize % 7]),
                    3 => (0x3000, 4 + b.u8() % 3, (b.u8() % 9) as u32),
                    4 => (0x6200, 0, (b.u8() % 20) as u32),
                    _ => (0x1010, 1 + b.u8() % 4, u32::from_le_bytes(*b"save")),
                };
                let size = if matches!(index, 0x3000..=0x3002 | 0x5F0A) { 1 } else { 4 };
                let size = if (index, sub) == (0x3000, 1) || (index, sub) == (0x3000, 2) || index == 0x6200 {
                    2
                } else {
                    size
                };
                let req = crate::encoder::download_request(index, sub, size, value);
                Action::Frame(self.cam21(da, sa, &req))
            }
            // Any extended frame, or a group of ours from another CA.
            6 => {
                if b.one_in(2) {
                    let pgn = [Pgn::EPOS, Pgn::ESPD, Pgn::PROPRIETARY_B, Pgn::EMCY, Pgn::CAM11][b.u8() as usize % 5];
                    let raw = 0x0C00_0000 | pgn.raw() << 8 | sa as u32;
                    Action::Frame(Frame::new(CanId::Ext(raw), &[b.u8(); 8]))
                } else {
                    let raw = b.u32() & 0x1FFF_FFFF;
                    let len = b.u8() % 9;
                    let d = [b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8(), b.u8()];
                    if b.one_in(8) {
                        Action::Frame(Frame::remote(CanId::Ext(raw), len))
                    } else {
                        Action::Frame(Frame::new(CanId::Ext(raw), &d[..len as usize]))
                    }
                }
            }
            // The times that matter to claiming: the 250 ms contention, the start delay.
            _ => Action::Advance(match b.u8() % 4 {
                0 => CONTENTION_MS * 1000 - 1 + (b.u8() % 3) as u64,
                1 => (b.u8() as u64) * 600,
                2 => 1000 * (b.u8() % 16) as u64,
                _ => 400_000,
            }),
        })
    }
}

/// The node as the checker sees it around one input.
#[derive(Clone, Copy, Debug)]
struct Seen {
    state: State,
    source: Option<Address>,
    address: Option<Address>,
    name: Name,
    /// 3000h.04..06: the priorities of Proprietary B, ESPD, EPOS.
    priorities: [u8; 3],
}

impl Seen {
    fn of(node: &J1939Node<Wv58mr>) -> Seen {
        let od = &node.context().od;
        let p = |s| od.value(0x3000, s).filter(|&v| v <= 7).unwrap_or(6) as u8;
        Seen {
            state: node.claimer().state(),
            source: node.source_address(),
            address: node.claimer().address(),
            name: name_of(od),
            priorities: [p(4), p(5), p(6)],
        }
    }

    fn priority_of(&self, pgn: Pgn) -> Option<u8> {
        match pgn {
            Pgn::PROPRIETARY_B => Some(self.priorities[0]),
            Pgn::ESPD => Some(self.priorities[1]),
            Pgn::EPOS => Some(self.priorities[2]),
            _ => None,
        }
    }
}

/// One call into the node.
#[derive(Clone, Copy, Debug)]
enum Input {
    Frame(Frame),
    Poll,
    StoreDone { ok: bool },
    Bus(od_core::BusEvent),
    Sample(Result<u32, SensorFault>),
}

/// A WV58MR channel, its parameter flash, a virtual clock and the checker's model.
pub struct J1939Rig {
    turns: Turns,
    node: J1939Node<Wv58mr>,
    flash: ParamFlash<RamFlash>,
    now: Instant,
    client: J1939Client,
    /// Pending stores (their masks), in order.
    stores: Vec<GroupMask>,
    sdo: SdoModel,
    download: Vec<u8>,
    /// The requester of the last CAM21 the server took (a timeout abort goes there).
    requester: Option<Address>,
    /// The requester whose save waits for the store.
    deferred: Option<Address>,
    expected: HashMap<(u16, u8), Expected>,
    /// Statistics.
    pub stats: J1939Stats,
}

impl J1939Rig {
    /// A WV58MR channel with `turns` whose factory flash holds `serial` and, if given, the
    /// address `address` in 5F0Ah.01, powered on.
    pub fn new(turns: Turns, serial: u32, address: Option<u8>) -> J1939Rig {
        let table = od_core::devices::wv58mr::table_of(turns);
        let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(table));
        let mut image = Image::new();
        for e in table.iter() {
            let v = match (e.index, e.sub) {
                (0x1018, 4) | (0x650B, 0) => serial,
                _ if e.hook == Hook::Core(od_core::od::CoreHook::PendingNodeId) => match address {
                    Some(a) => a as u32,
                    None => continue,
                },
                _ => continue,
            };
            image.set(Record::of(e, v)).expect("room for the factory records");
        }
        flash.write(&image).expect("blank flash");
        let node = J1939Node::boot(Wv58mr::new(turns), &flash.load());
        let mut rig = J1939Rig {
            turns,
            node,
            flash,
            now: Instant::ZERO,
            client: J1939Client::new(Client::new(table)),
            stores: Vec::new(),
            sdo: SdoModel::Idle,
            download: Vec::new(),
            requester: None,
            deferred: None,
            expected: HashMap::new(),
            stats: J1939Stats::default(),
        };
        rig.expect_current(GroupMask(GroupMask::ALL.0 | GroupMask::LSS.0));
        rig
    }

    /// The node.
    pub fn node(&self) -> &J1939Node<Wv58mr> {
        &self.node
    }

    /// The flash (to corrupt or inspect it).
    pub fn flash(&mut self) -> &mut ParamFlash<RamFlash> {
        &mut self.flash
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Decodes the next action from `b` for this node.
    pub fn decode(&mut self, b: &mut Bytes) -> Option<Action> {
        self.observe();
        self.client.decode(b)
    }

    fn observe(&mut self) {
        let s = Seen::of(&self.node);
        self.client.name = s.name;
        if let Some(a) = s.address {
            self.client.address = a.0;
        }
    }

    /// Runs every action `data` decodes to, checking after each input, then [`J1939Rig::settle`].
    pub fn run_bytes(&mut self, data: &[u8]) -> Result<(), Violation> {
        let mut b = Bytes::new(data);
        let mut n = 0;
        while let Some(a) = self.decode(&mut b) {
            self.apply(a).map_err(|v| Violation(format!("action {n} {a:?}: {v}")))?;
            n += 1;
        }
        self.settle()
    }

    fn expect_current(&mut self, mask: GroupMask) {
        let ctx = self.node.context();
        for (pos, e) in ctx.od.table().iter().enumerate() {
            if selected(e, mask) {
                let v = ctx.od.get(pos);
                let x = if v == e.default_value(ctx.node_id) { Expected::Default } else { Expected::Value(v) };
                self.expected.insert((e.index, e.sub), x);
            }
        }
    }

    /// Applies one action and checks every invariant after each input it makes.
    pub fn apply(&mut self, action: Action) -> Result<(), Violation> {
        match action {
            Action::Frame(f) => {
                self.stats.frames_in += 1;
                self.input(Input::Frame(f)).map(|_| ())
            }
            Action::Advance(us) => {
                let until = self.now.add_micros(us);
                let mut polls = 0;
                while let Some(t) = self.node.next_deadline().filter(|&t| t <= until && polls < MAX_POLLS_PER_ADVANCE) {
                    self.now = self.now.max(t);
                    self.input(Input::Poll)?;
                    polls += 1;
                }
                self.now = until;
                self.input(Input::Poll).map(|_| ())
            }
            Action::LatePoll(us) => {
                self.now = self.now.add_micros(us);
                self.input(Input::Poll).map(|_| ())
            }
            Action::StoreDone(ok) => {
                if self.stores.is_empty() {
                    return Ok(());
                }
                self.input(Input::StoreDone { ok }).map(|_| ())
            }
            Action::Bus(e) => self.input(Input::Bus(e)).map(|_| ()),
            Action::Sample(raw) => self.input(Input::Sample(raw)).map(|_| ()),
            Action::PowerCycle => self.power_cycle(),
        }
    }

    /// Ends a run: completes pending stores, lets every timeout pass, checks that a claimed node
    /// answers a CAM21 read of 1000h and a Request for EPOS, then power-cycles (checking the
    /// stored image) and checks that the claim stands again within the start delay and 250 ms.
    pub fn settle(&mut self) -> Result<(), Violation> {
        while !self.stores.is_empty() {
            self.apply(Action::StoreDone(true))?;
        }
        self.apply(Action::Advance(SDO_TIMEOUT_US + 100_000))?;
        ensure!(self.sdo == SdoModel::Idle, "SDO transfer still open after its timeout");
        if let Some(sa) = self.node.source_address() {
            let req = crate::encoder::upload_request(0x1000, 0);
            let sent = self.input(Input::Frame(self.client.cam21(sa.0, MASTER, &req)))?;
            let want = self.node.context().od.value(0x1000, 0).unwrap_or(0).to_le_bytes();
            let answer = [0x43, 0x00, 0x10, 0x00, want[0], want[1], want[2], want[3]];
            ensure!(sent.iter().any(|f| f.payload() == answer), "1000h read after the run answered {sent:02X?}");
            let pgn = Pgn::EPOS.raw().to_le_bytes();
            let sent = self.input(Input::Frame(J1939Client::pdu1(0xEA, 0xFF, MASTER, &pgn[..3])))?;
            ensure!(sent.len() == 1, "a Request for EPOS after the run answered {sent:02X?}");
        }
        self.power_cycle()?;
        self.apply(Action::Advance(160_000 + CONTENTION_MS * 1000))?;
        ensure!(
            matches!(self.node.claimer().state(), State::Claimed { .. }),
            "no claim stood 410 ms after power-on: {:?}",
            self.node.claimer().state()
        );
        Ok(())
    }

    fn power_cycle(&mut self) -> Result<(), Violation> {
        self.stats.power_cycles += 1;
        self.stats.inputs += 1;
        self.flash.flash().power_on();
        let loaded = self.flash.load();
        ensure!(loaded != Loaded::Invalid, "the flash holds no valid image after saves only");
        self.node = J1939Node::boot(Wv58mr::new(self.turns), &loaded);
        self.stores.clear();
        self.sdo = SdoModel::Idle;
        self.deferred = None;
        self.requester = None;
        let ctx = self.node.context();
        let stored = |index: u16, sub: u8| {
            let e = ctx.od.table().iter().find(|e| (e.index, e.sub) == (index, sub))?;
            let default = e.default_value(ctx.node_id);
            Some(match self.expected.get(&(index, sub))? {
                Expected::Default => (default, default),
                Expected::Value(v) => (*v, default),
            })
        };
        // 6200h is 3000h.03 under another index, in another group (D-J1939-14): when the two
        // were stored apart, the one that differs from its default wins, 3000h.03 if both do.
        let cycle = match (stored(0x3000, 3), stored(0x6200, 0)) {
            (Some((a, da)), Some((b, db))) => Some(if a != da || b == db { a } else { b }),
            _ => None,
        };
        // The 1003h history is a log: a condition the stored parameters raise at power-on (a
        // limit speed below the speed at rest) enters it at once, with 1001h set.
        let logging = ctx.od.value(0x1001, 0).is_some_and(|r| r != 0);
        for (pos, e) in ctx.od.table().iter().enumerate() {
            if logging && e.index == 0x1003 {
                continue;
            }
            if let Some(x) = self.expected.get(&(e.index, e.sub)) {
                let want = match (*x, (e.index, e.sub)) {
                    (_, (0x3000, 3) | (0x6200, 0)) if cycle.is_some() => cycle.unwrap_or(0),
                    (Expected::Default, _) => e.default_value(ctx.node_id),
                    (Expected::Value(v), _) => v,
                };
                ensure!(
                    ctx.od.get(pos) == want,
                    "power-on: {:04X}h.{:02X} = {:#X}, the saves stored {want:#X}",
                    e.index,
                    e.sub,
                    ctx.od.get(pos)
                );
            }
        }
        ensure!(self.node.claimer().state() == State::Off, "claiming before the first poll");
        check_values(self.node.context())?;
        self.apply(Action::Advance(0))
    }

    /// Feeds one input, carries out its outputs and checks everything; returns the frames sent.
    fn input(&mut self, input: Input) -> Result<Vec<Frame>, Violation> {
        self.stats.inputs += 1;
        let before = Seen::of(&self.node);
        let now = self.now;
        match input {
            Input::Frame(f) => self.node.on_frame(&f, now),
            Input::Poll => self.node.poll(now),
            Input::StoreDone { ok } => {
                let mask = self.stores[0];
                let ok = ok && self.flash.save(self.node.context(), mask).is_ok();
                if ok {
                    self.stats.stores += 1;
                    self.expect_current(mask);
                }
                self.node.store_done(if ok { Ok(()) } else { Err(()) }, now);
            }
            Input::Bus(e) => self.node.on_bus_event(e, now),
            Input::Sample(raw) => {
                let (device, ctx) = self.node.split();
                device.on_sample(ctx, raw, now);
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
        let after = Seen::of(&self.node);
        self.check(&input, &before, &after, &sent, &stores)
            .map_err(|v| Violation(format!("at {} us, {input:?}: {v}; sent {sent:02X?}", now.as_micros())))?;
        if let Input::StoreDone { .. } = input {
            self.stores.remove(0);
        }
        Ok(sent)
    }

    fn check(
        &mut self,
        input: &Input,
        before: &Seen,
        after: &Seen,
        sent: &[Frame],
        stores: &[GroupMask],
    ) -> Result<(), Violation> {
        check_values(self.node.context())?;
        // What it sends: its claims, and from its stood address the groups it owns.
        for f in sent {
            ensure!(!f.rtr && f.len == 8, "sent {f:?}: not an 8-byte data frame");
            let Ok(id) = Identifier::from_frame(f) else {
                return Err(Violation(format!("sent {f:?}: not a J1939 identifier")));
            };
            let sa = id.source();
            if id.pgn() == Pgn::ADDRESS_CLAIMED {
                ensure!(id.destination() == Some(Address::GLOBAL), "claim {f:?} not to the global address");
                ensure!(
                    f.payload() == before.name.to_le_bytes() || f.payload() == after.name.to_le_bytes(),
                    "claim {f:?} with another NAME than ours"
                );
                let cannot = sa == Address::NULL && after.state == State::CannotClaim;
                ensure!(
                    cannot || Some(sa) == before.address || Some(sa) == after.address,
                    "claim {f:?} from an address it does not claim ({:?} -> {:?})",
                    before.state,
                    after.state
                );
                continue;
            }
            ensure!(
                Some(sa) == before.source || Some(sa) == after.source,
                "sent {f:?} from {sa:?}, not an address whose claim stood ({:?} -> {:?})",
                before.state,
                after.state
            );
            let prio = id.priority().get();
            match id.pgn() {
                p if PROVIDED.contains(&p) => ensure!(
                    Some(prio) == before.priority_of(p) || Some(prio) == after.priority_of(p),
                    "group {f:?} at priority {prio}, 3000h says {:?}",
                    after.priorities
                ),
                Pgn::EMCY => ensure!(prio == EMCY_PRIORITY, "EMCY {f:?} at priority {prio}"),
                Pgn::ACKNOWLEDGEMENT => {
                    ensure!(id.destination() == Some(Address::GLOBAL) && f.data[0] == 1, "acknowledgement {f:?}")
                }
                Pgn::CAM11 => {
                    ensure!(id.destination().is_some_and(|d| d.is_unicast()), "CAM11 {f:?} not to a requester")
                }
                _ => return Err(Violation(format!("sent {f:?}: a group it does not own"))),
            }
        }
        self.check_claim(input, before, after, sent)?;
        self.check_requests(input, before, sent)?;
        // Stores: only a CAM21 "save".
        ensure!(stores.len() <= 1, "{} stores for one input", stores.len());
        if let Some(&mask) = stores.first() {
            let Some((_, d)) = self.cam21_to_us(input, before) else {
                return Err(Violation(format!("store {mask:?} without a CAM21 request")));
            };
            sdo_save(&d, self.sdo, &self.download, mask)?;
            self.stores.push(mask);
        }
        self.check_sdo(input, before, after, sent, !stores.is_empty())?;
        if let Input::Poll = input {
            if let Some(t) = self.node.next_deadline() {
                ensure!(t > self.now, "deadline {t:?} still due after the poll at {:?}", self.now);
            }
        }
        Ok(())
    }

    /// The address-claim state changes only as J1939-81 lets it.
    fn check_claim(&mut self, input: &Input, before: &Seen, after: &Seen, sent: &[Frame]) -> Result<(), Violation> {
        let (lo, hi) = od_core::devices::wv58mr::table_of(self.turns)
            .iter()
            .find(|e| e.hook == Hook::Core(od_core::od::CoreHook::PendingNodeId))
            .and_then(|e| e.limits())
            .map_or((0x80, 0xEF), |(lo, hi)| (lo as u8, hi as u8));
        if let Some(a) = after.address {
            ensure!((lo..=hi).contains(&a.0), "claims {a:?} outside {lo:02X}h..={hi:02X}h");
        }
        ensure!(
            after.source.is_none() || matches!(after.state, State::Claimed { .. }),
            "a source address in {:?}",
            after.state
        );
        if after.state == State::CannotClaim {
            self.stats.cannot_claim += 1;
        }
        let now = self.now;
        let stood = |since: Instant| now.micros_since(since) >= CONTENTION_MS * 1000;
        if let State::Claiming { since, .. } = after.state {
            ensure!(!(matches!(input, Input::Poll) && stood(since)), "a claim of 250 ms not made to stand by the poll");
        }
        let restart =
            before.state != State::Off && after.state != before.state && matches!(after.state, State::Starting { .. });
        if restart {
            // 3002h.01 / 3002h.02 (a CAM21 write to us) start claiming again.
            ensure!(self.cam21_to_us(input, before).is_some(), "claiming restarted on {input:?}");
            return Ok(());
        }
        match (input, before.state, after.state) {
            (_, b, a) if a == b => {}
            (Input::Poll, State::Off, State::Starting { .. } | State::Claiming { .. }) => {}
            (Input::Poll, State::Starting { at }, State::Claiming { since, .. }) => {
                ensure!(now >= at && since == now, "claim at {since:?}, due at {at:?}")
            }
            (Input::Poll, State::Claiming { address, since }, State::Claimed { address: a }) => {
                ensure!(a == address && stood(since), "claim of {address:?} at {since:?} stood at {now:?}");
                self.stats.claims_stood += 1;
            }
            (Input::Frame(f), b, a) if is_claim_of(f, before.address) => {
                let _ = (b, a);
            }
            (i, b, a) => return Err(Violation(format!("claim state {b:?} -> {a:?} on {i:?}"))),
        }
        // A contest for our address.
        if let Input::Frame(f) = input {
            if is_claim_of(f, before.address) {
                let ours = before.address.unwrap_or(Address::NULL);
                let other = Name::from_le_bytes(f.data);
                ensure!(sent.len() == 1, "{} frames for a contest", sent.len());
                if before.name.wins_against(other) {
                    ensure!(after.state == before.state, "contest won, but {:?} -> {:?}", before.state, after.state);
                    ensure!(raw_of(&sent[0]) == 0x18EE_FF00 | ours.0 as u32, "contest won, answered {:?}", sent[0]);
                    self.stats.contests_won += 1;
                } else {
                    ensure!(after.address != Some(ours), "contest lost, still at {ours:?}");
                    self.stats.contests_lost += 1;
                }
            }
        }
        Ok(())
    }

    /// A Request gets at most one answer, exactly the one J1939-21 gives.
    fn check_requests(&mut self, input: &Input, before: &Seen, sent: &[Frame]) -> Result<(), Violation> {
        let Input::Frame(f) = input else { return Ok(()) };
        let Ok(id) = Identifier::from_frame(f) else {
            ensure!(sent.is_empty(), "answered {f:?}, which is no J1939 frame");
            return Ok(());
        };
        match id.pgn() {
            Pgn::REQUEST => {}
            Pgn::ADDRESS_CLAIMED | Pgn::CAM21 => return Ok(()),
            _ => {
                ensure!(sent.is_empty(), "answered {f:?}");
                return Ok(());
            }
        }
        ensure!(sent.len() <= 1, "{} answers to the request {f:?}", sent.len());
        if !sent.is_empty() {
            self.stats.requests_answered += 1;
        }
        if f.len < 3 {
            ensure!(sent.is_empty(), "answered the short request {f:?}");
            return Ok(());
        }
        let pgn = Pgn::from_le_bytes([f.data[0], f.data[1], f.data[2]]);
        let da = id.destination().unwrap_or(Address::GLOBAL);
        let rq = id.source();
        let answer = sent.first().and_then(|a| Identifier::from_frame(a).ok());
        if pgn == Some(Pgn::ADDRESS_CLAIMED) {
            let claiming = matches!(before.state, State::Claiming { .. } | State::Claimed { .. });
            let asked = da == Address::GLOBAL || Some(da) == before.address;
            ensure!(sent.len() == (claiming && asked) as usize, "answers {sent:02X?} to a Request for Address Claimed");
            ensure!(answer.is_none_or(|a| a.pgn() == Pgn::ADDRESS_CLAIMED), "answer {sent:02X?} to {f:?}");
            return Ok(());
        }
        let Some(sa) = before.source else {
            ensure!(sent.is_empty(), "answered {f:?} before the claim stood");
            return Ok(());
        };
        let asked = rq.is_unicast() && (da == Address::GLOBAL || da == sa);
        match pgn {
            Some(p) if asked && PROVIDED.contains(&p) => {
                ensure!(answer.is_some_and(|a| a.pgn() == p), "a Request for {p:?} answered {sent:02X?}")
            }
            Some(p) if asked && da == sa => {
                let b = p.to_le_bytes();
                ensure!(
                    answer.is_some_and(|a| a.pgn() == Pgn::ACKNOWLEDGEMENT)
                        && sent[0].data == [0x01, 0xFF, 0xFF, 0xFF, rq.0, b[0], b[1], b[2]],
                    "a Request for {p:?} to us answered {sent:02X?}, not a NACK"
                )
            }
            _ => ensure!(sent.is_empty(), "answered {f:?}"),
        }
        Ok(())
    }

    /// The requester and SDO payload of `input` if it is a CAM21 the node serves: to its
    /// address whose claim stood, from a unicast address, 8 bytes.
    fn cam21_to_us(&self, input: &Input, before: &Seen) -> Option<(Address, [u8; 8])> {
        let Input::Frame(f) = input else { return None };
        let id = Identifier::from_frame(f).ok()?;
        let served = id.pgn() == Pgn::CAM21
            && before.source.is_some()
            && id.destination() == before.source
            && id.source().is_unicast()
            && f.len == 8;
        served.then_some((id.source(), f.data))
    }

    /// CAM21/CAM11 through the SDO server: at most one answer, fitting the request, to the
    /// requester; the timeout; the deferred answer of a save.
    fn check_sdo(
        &mut self,
        input: &Input,
        before: &Seen,
        after: &Seen,
        sent: &[Frame],
        stored: bool,
    ) -> Result<(), Violation> {
        let answers: Vec<(Address, [u8; 8])> = sent
            .iter()
            .filter_map(|f| Identifier::from_frame(f).ok().filter(|i| i.pgn() == Pgn::CAM11).map(|i| (i, f.data)))
            .map(|(i, d)| (i.destination().unwrap_or(Address::GLOBAL), d))
            .collect();
        ensure!(answers.len() <= 1, "{} CAM11 answers to one input", answers.len());
        let answer = answers.first().copied();
        if answer.is_some() {
            self.stats.cam_answers += 1;
        }
        match input {
            Input::Frame(_) => {
                let Some((rq, req)) = self.cam21_to_us(input, before) else {
                    ensure!(answer.is_none(), "CAM11 {answer:02X?} to {input:?}, not a CAM21 it serves");
                    return Ok(());
                };
                self.requester = Some(rq);
                let Some((to, a)) = answer else {
                    ensure!(req[0] >> 5 == 4 || stored, "CAM21 {req:02X?} unanswered");
                    if stored {
                        self.deferred = Some(rq);
                        if req[0] >> 5 == 0 {
                            self.stats.segmented_done += 1;
                        }
                    }
                    self.sdo = SdoModel::Idle;
                    return Ok(());
                };
                ensure!(to == rq, "CAM11 to {to:?}, the request came from {rq:?}");
                let (open, done) = sdo_answer_fits(&req, &a)?;
                self.stats.segmented_done += done as u64;
                if open {
                    let download = match (req[0] >> 5, self.sdo) {
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
                // 3002h: claiming starts again after the answer, the server is reset.
                if matches!(after.state, State::Starting { .. }) && after.state != before.state {
                    self.sdo = SdoModel::Idle;
                    self.deferred = None;
                }
            }
            Input::Poll => {
                if let SdoModel::Open { since, .. } = self.sdo {
                    if self.now.micros_since(since) >= SDO_TIMEOUT_US {
                        // The server times out; the abort goes out only from a stood address.
                        ensure!(
                            answer.is_some() == after.source.is_some(),
                            "transfer open since {} us: timeout abort {answer:02X?} at {} us",
                            since.as_micros(),
                            self.now.as_micros()
                        );
                        self.sdo = SdoModel::Idle;
                        if let Some((to, a)) = answer {
                            ensure!(Some(to) == self.requester, "timeout abort to {to:?}");
                            ensure!(a[0] == 0x80 && a[4..] == [0x00, 0x00, 0x04, 0x05], "poll sent CAM11 {a:02X?}");
                            self.stats.sdo_timeouts += 1;
                        }
                        return Ok(());
                    }
                }
                ensure!(answer.is_none(), "CAM11 {answer:02X?} from a poll with no transfer timed out");
            }
            Input::StoreDone { ok } => {
                if let Some((to, a)) = answer {
                    ensure!(Some(to) == self.deferred, "CAM11 {a:02X?} to {to:?} for no save waiting");
                    ensure!(
                        a[0] == 0x80
                            || *ok
                                && (a == [0x60, 0x10, 0x10, a[3], 0, 0, 0, 0]
                                    || (a[0] & 0xEF == 0x20 && a[1..] == [0; 7])),
                        "answer to a save: {a:02X?}"
                    );
                }
                self.deferred = None;
            }
            _ => ensure!(answer.is_none(), "CAM11 {answer:02X?} on {input:?}"),
        }
        Ok(())
    }
}

/// The raw 29-bit identifier (0 for an 11-bit one).
fn raw_of(f: &Frame) -> u32 {
    match f.id {
        CanId::Ext(raw) => raw,
        CanId::Std(_) => 0,
    }
}

/// Is `f` a well-formed Address Claimed from the address `ours` (a contest for it)?
fn is_claim_of(f: &Frame, ours: Option<Address>) -> bool {
    let Ok(id) = Identifier::from_frame(f) else { return false };
    id.pgn() == Pgn::ADDRESS_CLAIMED && f.len == 8 && ours.is_some_and(|a| id.source() == a)
}

/// Runs `data` against a WV58MR channel: `data[0]` picks the variant and the serial number,
/// `data[1]` the address the flash holds (0: none, the default EFh), the rest are actions.
/// Panics with the violation: the body of the J1939 fuzz target and proptest.
pub fn run_j1939(data: &[u8]) -> J1939Stats {
    let pick = data.first().copied().unwrap_or(0);
    let turns = TURNS[pick as usize % TURNS.len()];
    let serial = 0x0001_2345 + pick as u32 * 7919;
    let address = match data.get(1).copied().unwrap_or(0) {
        0 => None,
        b => Some(0x80 + b % 0x70),
    };
    let mut rig = J1939Rig::new(turns, serial, address);
    if let Err(v) = rig.run_bytes(data.get(2..).unwrap_or(&[])) {
        panic!("WV58MR {turns:?}: {v}");
    }
    rig.stats
}

/// The checker catches each fault it is meant to catch: the checks fed what a faulty node
/// would send or do after an input.
#[cfg(test)]
mod checker_fails {
    use super::*;
    use od_core::wire::j1939::AddressClaimed;

    /// A channel whose claim of EFh stood, and what the checker sees of it.
    fn claimed() -> (J1939Rig, Seen) {
        let mut rig = J1939Rig::new(Turns::Multi12, 0x1_2345, None);
        rig.apply(Action::Advance(500_000)).unwrap();
        let seen = Seen::of(&rig.node);
        assert_eq!(seen.source, Some(Address(0xEF)));
        (rig, seen)
    }

    fn violation(
        rig: &mut J1939Rig,
        input: Input,
        before: &Seen,
        after: &Seen,
        sent: &[Frame],
        stores: &[GroupMask],
    ) -> String {
        match rig.check(&input, before, after, sent, stores) {
            Err(v) => v.0,
            Ok(()) => panic!("the checker missed the fault"),
        }
    }

    fn ext(raw: u32, data: &[u8]) -> Frame {
        Frame::new(CanId::Ext(raw), data)
    }

    #[test]
    fn each_fault_is_caught() {
        let (mut rig, seen) = claimed();
        let poll = Input::Poll;
        // A group from an address that is not ours, and one we do not own.
        let v = violation(&mut rig, poll, &seen, &seen, &[ext(0x0CFC_5F80, &[0; 8])], &[]);
        assert!(v.contains("not an address whose claim stood"), "{v}");
        let v = violation(&mut rig, poll, &seen, &seen, &[ext(0x18FE_EEEF, &[0; 8])], &[]);
        assert!(v.contains("does not own"), "{v}");
        // EPOS at another priority than 3000h.06 gives.
        let v = violation(&mut rig, poll, &seen, &seen, &[ext(0x18FC_5FEF, &[0; 8])], &[]);
        assert!(v.contains("priority"), "{v}");
        // A claim with another NAME.
        let other = AddressClaimed { name: Name::from_raw(1) }.frame(Address(0xEF));
        let v = violation(&mut rig, poll, &seen, &seen, &[other], &[]);
        assert!(v.contains("another NAME"), "{v}");
        // Two answers to a Request for EPOS; none to one to us for another group.
        let req = Input::Frame(ext(0x18EA_FF00, &[0x5F, 0xFC, 0x00]));
        let epos = ext(0x0CFC_5FEF, &[0; 8]);
        let v = violation(&mut rig, req, &seen, &seen, &[epos, epos], &[]);
        assert!(v.contains("2 answers"), "{v}");
        let nack_due = Input::Frame(ext(0x18EA_EF00, &[0xEE, 0xFE, 0x00]));
        let v = violation(&mut rig, nack_due, &seen, &seen, &[], &[]);
        assert!(v.contains("not a NACK"), "{v}");
        // A store without a request; a CAM21 answered to another master, or not at all.
        let v = violation(&mut rig, poll, &seen, &seen, &[], &[GroupMask::ALL]);
        assert!(v.contains("without a CAM21"), "{v}");
        let read = Input::Frame(ext(0x1C06_EF21, &crate::encoder::upload_request(0x1000, 0)));
        let v = violation(&mut rig, read, &seen, &seen, &[ext(0x1C05_00EF, &[0x43, 0, 0x10, 0, 0, 0, 0, 0])], &[]);
        assert!(v.contains("the request came from"), "{v}");
        let v = violation(&mut rig, read, &seen, &seen, &[], &[]);
        assert!(v.contains("unanswered"), "{v}");
        // A claim standing before its 250 ms; a lost contest not given up.
        let since = rig.now;
        let claiming = Seen { state: State::Claiming { address: Address(0xEF), since }, source: None, ..seen };
        let v = violation(&mut rig, poll, &claiming, &seen, &[], &[]);
        assert!(v.contains("stood at"), "{v}");
        let lower = AddressClaimed { name: Name::from_raw(seen.name.raw() - 1) }.frame(Address(0xEF));
        let ours = AddressClaimed { name: seen.name }.frame(Address(0xEF));
        let v = violation(&mut rig, Input::Frame(lower), &seen, &seen, &[ours], &[]);
        assert!(v.contains("contest lost"), "{v}");
    }
}
