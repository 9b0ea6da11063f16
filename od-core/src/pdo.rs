//! SYNC consumer and PDOs (CiA 301 §7.2.2, §7.2.5): transmit PDOs on SYNC, timer and RTR,
//! receive PDOs into the mapped entries.
//!
//! The configuration lives in the dictionary (1005h, 14xxh/16xxh, 18xxh/1Axxh); [`Pdos`]
//! keeps a copy resolved for speed: identifiers as [`CanId`]s and every mapping as a list of
//! (dictionary position, byte count), so a SYNC packs a TPDO without a dictionary search.
//! The copy is taken at boot-up ([`Pdos::reset`]) and kept current by the write rules
//! ([`Pdos::on_write`]), which every SDO write to a hooked PDO entry passes first.
//!
//! Which transmission types a PDO accepts, when a COB-ID or a mapping may change and how the
//! event timer behaves follow the SIKO manuals and CiA 301 as `docs/decisions.md`
//! ("SYNC and PDO", D-PDO-n) records.

use crate::abort::Abort;
use crate::context::Context;
use crate::frame::{CanId, Frame, RxId};
use crate::nmt::NmtState;
use crate::od::{CoreHook, DataType, Od, MAX_ENTRIES};
use crate::time::{earliest, Instant};

/// Most transmit PDOs a node has (18xxh/1Axxh for xx = 00..03); further ones are not served.
pub const MAX_TPDOS: usize = 4;
/// Most receive PDOs a node has (14xxh/16xxh for xx = 00..03); further ones are not served.
pub const MAX_RPDOS: usize = 4;
/// Most objects one PDO maps (CiA 301 allows 64 one-bit objects; whole bytes are supported,
/// so eight fill a PDO).
pub const MAX_MAPPED: usize = 8;

/// COB-ID bit 31: the PDO does not exist (is invalid).
pub const COB_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: TPDO — no RTR allowed; 1005h — the node produces SYNC.
pub const COB_NO_RTR: u32 = 1 << 30;
/// COB-ID bit 29: 29-bit identifier.
pub const COB_EXTENDED: u32 = 1 << 29;

/// Transmission type FCh: synchronous, sent only on RTR (data sampled at the SYNC).
pub const TYPE_SYNC_RTR: u8 = 0xFC;
/// Transmission type FDh: asynchronous, sent only on RTR.
pub const TYPE_RTR: u8 = 0xFD;
/// Transmission type FEh: asynchronous, manufacturer-specific event (here: the event timer).
pub const TYPE_ASYNC_MANUF: u8 = 0xFE;
/// Transmission type FFh: asynchronous, device-profile event (here: the event timer).
pub const TYPE_ASYNC_PROFILE: u8 = 0xFF;

// Positions are kept in a byte; the dictionary is checked to fit when it is built.
const _: () = assert!(MAX_ENTRIES < NONE as usize);
const NONE: u8 = 0xFF;

/// The answer to a remote request on an RPDO, as the device gives it
/// ([`crate::device::CanopenDevice::on_rpdo_rtr`]): [`RtrReply::send`] puts a TPDO's current
/// data on the RPDO's identifier, at the moment the device calls it.
pub struct RtrReply<'a> {
    pdos: &'a Pdos,
    rpdo: u8,
}

impl<'a> RtrReply<'a> {
    /// The reply to a remote request on RPDO `rpdo` (0-based).
    pub fn new(pdos: &'a Pdos, rpdo: u8) -> RtrReply<'a> {
        RtrReply { pdos, rpdo }
    }

    /// Sends TPDO `tpdo`'s current data (0-based) on the RPDO's identifier ([`Pdos::reply`]).
    pub fn send(&self, ctx: &mut Context, tpdo: u8) {
        self.pdos.reply(ctx, self.rpdo, tpdo);
    }
}

/// The answer to a remote request on a TPDO, as the device gives it
/// ([`crate::device::CanopenDevice::on_tpdo_rtr`]): [`RtrAnswer::send`] puts the TPDO's data
/// on its identifier ([`Pdos::answer_rtr`]), at the moment the device calls it.
pub struct RtrAnswer<'a> {
    pdos: &'a Pdos,
    tpdo: u8,
}

impl<'a> RtrAnswer<'a> {
    /// The answer to a remote request on TPDO `tpdo` (0-based).
    pub fn new(pdos: &'a Pdos, tpdo: u8) -> RtrAnswer<'a> {
        RtrAnswer { pdos, tpdo }
    }

    /// Sends the TPDO's data (sampled at the last SYNC for type FCh, else current).
    pub fn send(&self, ctx: &mut Context) {
        self.pdos.answer_rtr(ctx, self.tpdo);
    }
}

/// What a received frame was for the PDO layer.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum PdoEvent {
    /// Not a PDO or SYNC frame, or one this node ignores in its state.
    None,
    /// A SYNC was consumed (PRE-OPERATIONAL or OPERATIONAL). Bit `n` of `rpdos` is set when
    /// synchronous RPDO `n` wrote its mapped entries at this SYNC.
    Sync {
        /// Synchronous RPDOs applied at this SYNC (bit n = RPDO n, 0-based).
        rpdos: u8,
    },
    /// RPDO `n` (0-based) was written into the dictionary.
    Rpdo(u8),
    /// A remote frame asked for RPDO `n` (0-based) in OPERATIONAL. CiA 301 has no answer; a
    /// device that answers (the AP10T returns its set points) does so in
    /// `CanopenDevice::on_rpdo_rtr` with an [`RtrReply`].
    RpdoRtr(u8),
    /// A remote frame asked for TPDO `n` (0-based), which accepts it (OPERATIONAL, COB-ID
    /// bit 30 = 0): the node answers through `CanopenDevice::on_tpdo_rtr`, by default with
    /// [`Pdos::answer_rtr`] (the AP10T adds its data identifier to the answer).
    Rtr(u8),
}

/// One mapped object: where its value is and how many of its low bytes the PDO carries.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Slice {
    /// Dictionary position, [`NONE`] for a dummy (RPDO only: bytes skipped).
    pos: u8,
    /// The first byte's place in the payload (0..=7): the bytes of the slices before. The
    /// slice's own bytes (1..=4) run to the next slice's place, the last one's to the
    /// mapping's length.
    at: u8,
}

impl Slice {
    const EMPTY: Slice = Slice { pos: NONE, at: 0 };
}

/// A PDO's mapping resolved against the dictionary (equal to another when it maps the same:
/// the slots past `count` do not count).
#[derive(Clone, Copy, Eq, Debug)]
struct Mapping {
    slices: [Slice; MAX_MAPPED],
    count: u8,
    /// Payload length in bytes.
    len: u8,
    /// False when the stored mapping names no valid object: the PDO is not used.
    ok: bool,
}

impl PartialEq for Mapping {
    fn eq(&self, other: &Mapping) -> bool {
        (self.len, self.ok, self.slices()) == (other.len, other.ok, other.slices())
    }
}

impl Mapping {
    const EMPTY: Mapping = Mapping { slices: [Slice::EMPTY; MAX_MAPPED], count: 0, len: 0, ok: false };

    #[inline(always)]
    fn slices(&self) -> &[Slice] {
        &self.slices[..(self.count as usize).min(MAX_MAPPED)]
    }
}

/// Dictionary positions of one PDO's communication parameters.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Params {
    /// Sub 1 COB-ID.
    cob: u8,
    /// Sub 2 transmission type ([`NONE`] if not declared).
    ttype: u8,
    /// Sub 3 inhibit time ([`NONE`] if not declared).
    inhibit: u8,
    /// Sub 5 event timer ([`NONE`] if not declared).
    event: u8,
    /// The event timer is writable: an asynchronous TPDO (D-PDO-3).
    asynchronous: bool,
}

impl Params {
    const EMPTY: Params = Params { cob: NONE, ttype: NONE, inhibit: NONE, event: NONE, asynchronous: false };

    /// The record `comm` (1400h + n, 1800h + n), if it declares a COB-ID.
    fn load(od: &Od, comm: u16) -> Option<Params> {
        let at = |sub| od.pos(comm, sub).map_or(NONE, |p| p as u8);
        let cob = at(1);
        if cob == NONE {
            return None;
        }
        let event = at(5);
        let asynchronous = event != NONE && od.entry(event as usize).access.writable();
        Some(Params { cob, ttype: at(2), inhibit: at(3), event, asynchronous })
    }

    fn get(od: &Od, pos: u8, default: u32) -> u32 {
        if pos == NONE {
            default
        } else {
            od.get(pos as usize)
        }
    }
}

/// A PDO, transmit or receive: its parameters, its mapping and its state.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Pdo {
    params: Params,
    map: Mapping,
    id: CanId,
    valid: bool,
    /// COB-ID bit 30 clear: a TPDO answers remote requests (an RPDO's bit 30 is reserved).
    rtr: bool,
    ttype: u8,
    /// SYNCs counted towards the next transmission (TPDO types 1..=240).
    count: u8,
    /// A TPDO of type FCh: the data sampled at the last SYNC. A synchronous RPDO: the data
    /// received, written at the next SYNC.
    held: Option<[u8; 8]>,
}

/// A transmit PDO.
type Tpdo = Pdo;
/// A receive PDO.
type Rpdo = Pdo;

impl Pdo {
    const EMPTY: Pdo = Pdo {
        params: Params::EMPTY,
        map: Mapping::EMPTY,
        id: CanId::Std(0),
        valid: false,
        rtr: false,
        ttype: 0,
        count: 0,
        held: None,
    };

    fn event_driven(&self) -> bool {
        matches!(self.ttype, TYPE_ASYNC_MANUF | TYPE_ASYNC_PROFILE)
    }

    /// Takes COB-ID `cob` (checked or loaded).
    fn set_cob(&mut self, cob: u32) {
        self.id = CanId::from_cob_id(cob);
        self.valid = cob & COB_INVALID == 0;
        self.rtr = cob & COB_NO_RTR == 0;
    }
}

/// PDO and SYNC state: the resolved configuration, counters and timers.
#[derive(Clone)]
pub struct Pdos {
    /// [`CanId::key`] of the SYNC identifier (1005h), `u32::MAX` when the node consumes no
    /// SYNC: one compare per frame ([`Pdos::is_sync`]).
    sync_key: u32,
    /// The TPDOs a SYNC counts for (valid, mapped, type 1..=240), one bit each: a SYNC
    /// visits only them. Kept by [`Pdos::reset`] and [`Pdos::on_write`], which alone change
    /// those three.
    sync_tx: u8,
    /// The TPDOs a SYNC samples (valid, mapped, type FCh), one bit each, kept alike.
    sync_sample: u8,
    /// The TPDOs, the first `ntpdo` of them declared; the others stay [`Pdo::EMPTY`] (invalid,
    /// unmapped), so that a walk over the whole array finds only declared ones.
    tpdo: [Tpdo; MAX_TPDOS],
    ntpdo: u8,
    /// The RPDOs, the first `nrpdo` of them declared, the others [`Pdo::EMPTY`] alike.
    rpdo: [Rpdo; MAX_RPDOS],
    nrpdo: u8,
    /// Each TPDO's next event-timer transmission (types FEh/FFh with a non-zero event timer);
    /// `None` for every one outside OPERATIONAL.
    next: [Option<Instant>; MAX_TPDOS],
    /// Each TPDO's last event-driven transmission (for the inhibit time).
    last: [Option<Instant>; MAX_TPDOS],
    /// The node is OPERATIONAL and the PDOs run.
    running: bool,
    /// Earliest event-timer transmission.
    deadline: Option<Instant>,
    /// Changes with every identifier the node listens to.
    generation: u32,
}

// A SYNC picks its TPDOs by bit number without a bounds check.
// One loop serves both directions where they are handled alike.
const _: () = assert!(MAX_TPDOS.is_power_of_two() && MAX_TPDOS <= 8 && MAX_RPDOS == MAX_TPDOS);

impl Default for Pdos {
    fn default() -> Pdos {
        Pdos {
            sync_key: u32::MAX,
            sync_tx: 0,
            sync_sample: 0,
            tpdo: [Pdo::EMPTY; MAX_TPDOS],
            ntpdo: 0,
            rpdo: [Pdo::EMPTY; MAX_RPDOS],
            nrpdo: 0,
            next: [None; MAX_TPDOS],
            last: [None; MAX_TPDOS],
            running: false,
            deadline: None,
            generation: 0,
        }
    }
}

impl Pdos {
    /// A number that changes whenever an identifier the node receives (SYNC, RPDO, TPDO
    /// remote requests) changes, and at every boot-up.
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// Marks the received identifiers changed (the node-ID, 1005h, a PDO COB-ID).
    pub fn touch_rx_ids(&mut self) {
        self.generation = self.generation.wrapping_add(1);
    }

    /// The frames the PDO layer receives: SYNC (data), each valid RPDO (data, and remote: the
    /// device may answer an RPDO remote request, [`crate::device::CanopenDevice::on_rpdo_rtr`]), and each
    /// valid TPDO that accepts a remote request (remote). Pushed into `out` (duplicates and
    /// overflow skipped).
    pub fn rx_ids<const N: usize>(&self, out: &mut heapless::Vec<RxId, N>) {
        let mut push = |id: RxId| {
            if !out.contains(&id) {
                let _ = out.push(id);
            }
        };
        if let Some(id) = self.sync_id() {
            push(RxId::data(id));
        }
        for r in self.rpdo.iter().filter(|r| r.valid) {
            push(RxId::data(r.id));
            push(RxId::remote(r.id));
        }
        for t in self.tpdo.iter().filter(|t| t.valid && t.rtr) {
            push(RxId::remote(t.id));
        }
    }

    #[inline(always)]
    fn refresh_sync_tx(&mut self) {
        let (mut counted, mut sampled) = (0, 0);
        for (n, t) in self.tpdo.iter().enumerate() {
            if t.valid && t.map.ok {
                match t.ttype {
                    1..=240 => counted |= 1 << n,
                    TYPE_SYNC_RTR => sampled |= 1 << n,
                    _ => {}
                }
            }
        }
        self.sync_tx = counted;
        self.sync_sample = sampled;
    }

    /// Is `frame` a SYNC (a data frame on the 1005h identifier)?
    #[inline(always)]
    pub fn is_sync(&self, frame: &Frame) -> bool {
        frame.id.key() == self.sync_key && !frame.rtr
    }

    /// The SYNC identifier's [`CanId::key`] (1005h), `u32::MAX` if the node has none.
    #[inline]
    pub fn sync_key(&self) -> u32 {
        self.sync_key
    }

    /// The SYNC identifier (1005h), if the node has one.
    #[inline]
    pub fn sync_id(&self) -> Option<CanId> {
        CanId::from_key(self.sync_key)
    }

    /// The declared TPDOs (the tests' view; the code walks the whole arrays).
    #[cfg(test)]
    fn tpdos(&self) -> &[Tpdo] {
        &self.tpdo[..(self.ntpdo as usize).min(MAX_TPDOS)]
    }

    /// The declared RPDOs.
    #[cfg(test)]
    fn rpdos(&self) -> &[Rpdo] {
        &self.rpdo[..(self.nrpdo as usize).min(MAX_RPDOS)]
    }

    /// PDO `n` of a direction (`n` below its count).
    #[inline(always)]
    fn pdo(&mut self, rx: bool, n: usize) -> &mut Pdo {
        // `n` is below the direction's count, at most the array's length: the remainder only
        // spares a bounds check.
        if rx {
            &mut self.rpdo[n % MAX_RPDOS]
        } else {
            &mut self.tpdo[n % MAX_TPDOS]
        }
    }

    /// (Re)starts TPDO `n`'s event timer at `now`: its first transmission one period later
    /// if it runs (OPERATIONAL, valid, type FEh/FFh, a period set), else none.
    fn restart(&mut self, od: &Od, n: usize, now: Instant) {
        let t = &self.tpdo[n];
        let ms = Params::get(od, t.params.event, 0);
        self.next[n] = (self.running && t.valid && t.event_driven() && ms != 0).then(|| now.add_millis(ms as u64));
    }

    /// Recomputes what follows from the PDOs' state: the TPDOs a SYNC concerns and the
    /// earliest event-timer transmission (every `next` is `None` outside OPERATIONAL).
    fn refresh(&mut self) {
        self.refresh_sync_tx();
        self.deadline = self.next.iter().fold(None, |a, &b| earliest(a, b));
    }
}

impl Pdos {
    /// Re-reads the PDO configuration from the dictionary (boot-up after power-on and every NMT
    /// reset). The node is PRE-OPERATIONAL: nothing runs, SYNC counters start from zero.
    pub fn reset(&mut self, od: &Od, now: Instant) {
        let _ = now;
        self.touch_rx_ids();
        self.sync_key = od.pos(0x1005, 0).map_or(u32::MAX, |pos| CanId::from_cob_id(od.get(pos)).key());
        self.running = false;
        self.next = [None; MAX_TPDOS];
        self.last = [None; MAX_TPDOS];
        self.deadline = None;
        self.ntpdo = self.load(od, false);
        self.nrpdo = self.load(od, true);
        self.refresh();
    }

    /// Reads the PDOs of one direction from their records (14xxh/16xxh, 18xxh/1Axxh), up to
    /// the first missing one; how many there are.
    fn load(&mut self, od: &Od, rx: bool) -> u8 {
        let base = if rx { 0x1400 } else { 0x1800 };
        let mut n = 0;
        while n < MAX_TPDOS {
            let comm = base + n as u16;
            let Some(params) = Params::load(od, comm) else { break };
            let p = self.pdo(rx, n);
            p.params = params;
            p.ttype = Params::get(od, params.ttype, TYPE_ASYNC_PROFILE as u32) as u8;
            p.count = 0;
            p.held = None;
            p.set_cob(od.get(params.cob as usize));
            // A mapping that does not resolve leaves the PDO unused (`ok` false), as does a
            // missing mapping record (a count past `MAX_MAPPED` resolves to nothing).
            let count = od.value(comm + 0x200, 0).map_or(u8::MAX, |c| c as u8);
            let _ = resolve(od, comm + 0x200, count, rx, &mut p.map);
            n += 1;
        }
        n as u8
    }

    /// Starts or stops the PDOs after an NMT state change: entering OPERATIONAL restarts the SYNC
    /// counters and the event timers (first transmission one period later); leaving it stops
    /// everything and drops synchronous RPDO data not yet applied.
    pub fn on_state(&mut self, od: &Od, nmt: NmtState, now: Instant) {
        let operational = nmt == NmtState::Operational;
        if operational == self.running {
            return;
        }
        self.running = operational;
        for p in &mut self.tpdo {
            p.count = 0;
            p.held = None;
        }
        for p in &mut self.rpdo {
            p.count = 0;
            p.held = None;
        }
        self.last = [None; MAX_TPDOS];
        for n in 0..MAX_TPDOS {
            self.restart(od, n, now);
        }
        self.refresh();
    }

    /// Handles a frame that may be a SYNC, an RPDO or a PDO remote request.
    pub fn on_frame(&mut self, ctx: &mut Context, nmt: NmtState, frame: &Frame, now: Instant) -> PdoEvent {
        if self.is_sync(frame) {
            return self.on_sync(ctx, nmt);
        }
        self.on_pdo(ctx, frame, now)
    }

    /// Handles a frame that is no SYNC ([`Pdos::is_sync`]) and may be an RPDO or a PDO remote
    /// request.
    pub fn on_pdo(&mut self, ctx: &mut Context, frame: &Frame, now: Instant) -> PdoEvent {
        let _ = now;
        if !self.running {
            return PdoEvent::None;
        }
        if frame.rtr {
            if let Some(n) = find(&self.tpdo, frame.id) {
                let t = &self.tpdo[n as usize];
                return if t.rtr && t.map.ok { PdoEvent::Rtr(n) } else { PdoEvent::None };
            }
            return match find(&self.rpdo, frame.id) {
                Some(n) => PdoEvent::RpdoRtr(n),
                None => PdoEvent::None,
            };
        }
        let Some(n) = find(&self.rpdo, frame.id) else { return PdoEvent::None };
        let r = &mut self.rpdo[n as usize];
        // CiA 301: fewer bytes than mapped → not processed; more → the first ones are used.
        if !r.map.ok || frame.len < r.map.len {
            return PdoEvent::None;
        }
        if r.ttype <= 240 {
            r.held = Some(frame.data);
            return PdoEvent::None;
        }
        if apply(&mut ctx.od, &r.map, &frame.data) {
            PdoEvent::Rpdo(n)
        } else {
            PdoEvent::None
        }
    }

    /// Handles a SYNC (the caller has matched the frame with [`Pdos::sync_id`]): sends the
    /// synchronous TPDOs that are due and applies the synchronous RPDOs received;
    /// [`PdoEvent::Sync`] names them, or [`PdoEvent::None`] when the node ignores SYNC (STOPPED).
    #[inline(always)]
    pub fn on_sync(&mut self, ctx: &mut Context, nmt: NmtState) -> PdoEvent {
        if !self.running {
            // PRE-OPERATIONAL consumes SYNC (the device may use it); STOPPED does not.
            return if nmt == NmtState::PreOperational { PdoEvent::Sync { rpdos: 0 } } else { PdoEvent::None };
        }
        let mut due = self.sync_tx;
        while due != 0 {
            let t = &mut self.tpdo[due.trailing_zeros() as usize % MAX_TPDOS];
            due &= due - 1;
            // One store either way: the count restarts at the SYNC that sends.
            let count = t.count + 1;
            if count < t.ttype {
                t.count = count;
            } else {
                t.count = 0;
                let data = pack(&ctx.od, &t.map);
                ctx.out.send(Frame { id: t.id, rtr: false, len: t.map.len, data });
            }
        }
        // The rarer work, out of line: TPDOs sampled (type FCh), RPDOs written.
        let rpdos = if self.sync_sample | self.nrpdo == 0 { 0 } else { self.sync_rest(&mut ctx.od) };
        PdoEvent::Sync { rpdos }
    }

    /// At a SYNC, after the transmissions: samples the TPDOs of type FCh and writes the
    /// synchronous RPDO data received since the last SYNC; the RPDOs written, one bit each.
    #[inline(never)]
    fn sync_rest(&mut self, od: &mut Od) -> u8 {
        let mut due = self.sync_sample;
        while due != 0 {
            let t = &mut self.tpdo[due.trailing_zeros() as usize % MAX_TPDOS];
            due &= due - 1;
            t.held = Some(packed(od, &t.map));
        }
        let mut rpdos = 0;
        for n in 0..MAX_RPDOS {
            let r = &mut self.rpdo[n];
            if let Some(data) = r.held.take() {
                if apply(od, &r.map, &data) {
                    rpdos |= 1 << n;
                }
            }
        }
        rpdos
    }

    /// Sends the event-timer TPDOs that are due.
    pub fn poll(&mut self, ctx: &mut Context, now: Instant) {
        if !self.running || self.deadline.is_none_or(|d| d > now) {
            return;
        }
        for n in 0..MAX_TPDOS {
            let Some(due) = self.next[n] else { continue };
            if due > now {
                continue;
            }
            let t = &self.tpdo[n];
            // The inhibit time (100 µs units) holds the transmission back, if declared.
            let inhibit = Params::get(&ctx.od, t.params.inhibit, 0) as u64 * 100;
            if let Some(last) = self.last[n] {
                let free = last.add_micros(inhibit);
                if inhibit > 0 && free > now {
                    self.next[n] = Some(free);
                    continue;
                }
            }
            if t.valid && t.map.ok {
                send(ctx, t.id, &t.map, None);
                self.last[n] = Some(now);
            }
            // A changed event timer takes effect now, at the timer's next operation (manuals).
            let period = Params::get(&ctx.od, t.params.event, 0) as u64 * 1000;
            self.next[n] = match period {
                0 => None,
                us => {
                    let next = due.add_micros(us);
                    Some(if next > now { next } else { now.add_micros(us) })
                }
            };
        }
        self.refresh();
    }

    /// When the next event-timer TPDO is due (`None` outside OPERATIONAL).
    pub fn next_deadline(&self) -> Option<Instant> {
        self.deadline
    }

    /// Sends TPDO `tpdo`'s current data on RPDO `rpdo`'s identifier: the answer to a remote
    /// request on an RPDO (`PdoEvent::RpdoRtr`) for a device whose manual defines one (the AP10T
    /// reads its set points back this way). Nothing is sent for a PDO that does not exist, is
    /// invalid or outside OPERATIONAL.
    pub fn reply(&self, ctx: &mut Context, rpdo: u8, tpdo: u8) {
        let (Some(r), Some(t)) = (self.rpdo.get(rpdo as usize), self.tpdo.get(tpdo as usize)) else { return };
        if self.running && r.valid && t.map.ok {
            send(ctx, r.id, &t.map, None);
        }
    }

    /// Answers a remote request for TPDO `n` ([`PdoEvent::Rtr`]): the data sampled at the
    /// last SYNC (type FCh) or else its current data, on its identifier.
    pub fn answer_rtr(&self, ctx: &mut Context, n: u8) {
        let Some(t) = self.tpdo.get(n as usize) else { return };
        if t.valid && t.map.ok {
            send(ctx, t.id, &t.map, t.held);
        }
    }

    /// Sets the event timer (18xxh.05) of TPDO `n` (0-based) to `ms`, with the checks and timing
    /// of an SDO write: for a device whose own entry mirrors it (the encoders' 6200h cycle timer).
    pub fn set_event_timer(&mut self, ctx: &mut Context, n: u8, ms: u16, now: Instant) -> Result<(), Abort> {
        let params = self.tpdo.get(n as usize).map(|t| t.params).filter(|p| p.event != NONE);
        let params = params.ok_or(Abort::NO_OBJECT)?;
        if !params.asynchronous {
            return Err(Abort::READ_ONLY);
        }
        self.write_event_timer(n as usize, ms as u32, now)?;
        self.refresh();
        ctx.od.set(params.event as usize, ms as u32);
        Ok(())
    }

    /// Checks a write to 1005h or a PDO parameter (entry `pos`, rule `hook`) and applies it to the
    /// running PDOs; on `Ok` the node stores the value.
    #[inline(never)]
    pub fn on_write(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        hook: CoreHook,
        pos: usize,
        value: u32,
        now: Instant,
    ) -> Result<(), Abort> {
        let result = match hook {
            CoreHook::SyncCobId => self.write_sync(nmt, value),
            CoreHook::PdoCobId | CoreHook::PdoTransmissionType | CoreHook::PdoEventTimer | CoreHook::PdoMapping => {
                self.write_pdo(ctx, nmt, hook, pos, value, now)
            }
            _ => Err(Abort::GENERAL),
        };
        // What the rules may have changed: the SYNC's TPDOs and the earliest event timer.
        self.refresh();
        result
    }

    /// A PDO parameter: which PDO the entry's index names (14xxh/16xxh RPDO, 18xxh/1Axxh
    /// TPDO), then the rule of its kind.
    fn write_pdo(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        hook: CoreHook,
        pos: usize,
        value: u32,
        now: Instant,
    ) -> Result<(), Abort> {
        let e = ctx.od.entry(pos);
        let (index, sub) = (e.index, e.sub);
        // 1400h..1BFFh: bit 11 (1800h) TPDO, bit 9 (x200h) mapping, the low 9 bits the number.
        let rel = index.wrapping_sub(0x1400);
        let (rx, mapping, n) = (rel & 0x400 == 0, rel & 0x200 != 0, (rel & 0x1FF) as usize);
        let count = if rx { self.nrpdo } else { self.ntpdo };
        if rel >= 0x800 || n >= count as usize {
            return Err(Abort::UNSUPPORTED_ACCESS);
        }
        match hook {
            CoreHook::PdoMapping if mapping => self.write_mapping(ctx, nmt, rx, n, index, sub, value),
            CoreHook::PdoCobId if !mapping => self.write_cob(ctx, nmt, rx, n, value, now),
            CoreHook::PdoTransmissionType if !mapping => self.write_type(&ctx.od, rx, n, value, now),
            // RPDO deadline monitoring is not supported (no manual has it).
            CoreHook::PdoEventTimer if !mapping && !rx && sub == 5 => self.write_event_timer(n, value, now),
            _ => Err(Abort::UNSUPPORTED_ACCESS),
        }
    }

    /// 1005h: PRE-OPERATIONAL only, as the object tables print it (08000022h otherwise; issue
    /// 13 point 13, D-PDO-9); bit 30 (produce SYNC) cannot be set; bit 31 is not used (D-PDO-1).
    fn write_sync(&mut self, nmt: NmtState, value: u32) -> Result<(), Abort> {
        if nmt != NmtState::PreOperational {
            return Err(Abort::DEVICE_STATE);
        }
        if value & COB_NO_RTR != 0 {
            return Err(Abort::INVALID_VALUE);
        }
        let key = checked_id(value, true)?.key();
        if self.sync_key != key {
            self.sync_key = key;
            self.touch_rx_ids();
        }
        Ok(())
    }

    /// A COB-ID (D-PDO-2): the PDO takes it at once; a TPDO restarts its SYNC count and event
    /// timer, an RPDO drops data not yet applied.
    fn write_cob(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        rx: bool,
        n: usize,
        value: u32,
        now: Instant,
    ) -> Result<(), Abort> {
        let p = self.pdo(rx, n);
        check_cob(nmt, ctx.od.get(p.params.cob as usize), value, p.map.ok)?;
        p.set_cob(value);
        p.count = 0;
        p.held = None;
        if !rx {
            self.restart(&ctx.od, n, now);
        }
        self.touch_rx_ids();
        Ok(())
    }

    /// A transmission type (D-PDO-3). A TPDO whose type changes restarts its SYNC count and
    /// starts or stops its event timer; an RPDO drops data not yet applied.
    fn write_type(&mut self, od: &Od, rx: bool, n: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let ttype = u8::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        let p = self.pdo(rx, n);
        let allowed = if rx { rpdo_type_allowed(ttype) } else { tpdo_type_allowed(p.params.asynchronous, ttype) };
        if !allowed {
            return Err(Abort::INVALID_VALUE);
        }
        if rx || ttype != p.ttype {
            let was_event = p.event_driven();
            p.ttype = ttype;
            p.count = 0;
            p.held = None;
            // FEh and FFh alike keep the timer running; every other change starts or stops it.
            let keeps_timer = was_event && p.event_driven();
            if !rx && !keeps_timer {
                self.restart(od, n, now);
            }
        }
        Ok(())
    }

    /// The event timer (D-PDO-4): 0 stops the timer at once; a new period on a running timer
    /// applies from its next expiry (the manuals' "next timer operation"); a stopped timer given a
    /// period starts now and fires one period later.
    fn write_event_timer(&mut self, n: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let ms = u16::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        let t = &self.tpdo[n];
        if ms == 0 {
            self.next[n] = None;
        } else if self.next[n].is_none() && self.running && t.valid && t.event_driven() {
            self.next[n] = Some(now.add_millis(ms as u64));
        }
        Ok(())
    }

    /// A mapping write (D-PDO-5) to record `index`: PRE-OPERATIONAL only; only while the PDO
    /// is invalid; the objects (sub 1..) only while sub 0 is 0; sub 0 = n checks the n objects
    /// and their total length, and makes the mapping the PDO's.
    #[allow(clippy::too_many_arguments)]
    fn write_mapping(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        rx: bool,
        n: usize,
        index: u16,
        sub: u8,
        value: u32,
    ) -> Result<(), Abort> {
        if nmt != NmtState::PreOperational {
            return Err(Abort::DEVICE_STATE);
        }
        if self.pdo(rx, n).valid {
            return Err(Abort::INVALID_VALUE);
        }
        if sub != 0 {
            if ctx.od.value(index, 0).unwrap_or(0) != 0 {
                return Err(Abort::INVALID_VALUE);
            }
            // An object may be written before it is used; it is checked now all the same.
            if value != 0 {
                slice(&ctx.od, value, rx)?;
            }
            return Ok(());
        }
        let count = u8::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        let mut map = Mapping::EMPTY;
        resolve(&ctx.od, index, count, rx, &mut map)?;
        self.pdo(rx, n).map = map;
        Ok(())
    }
}

/// The first PDO of `list` that is valid on identifier `id`.
fn find(list: &[Pdo], id: CanId) -> Option<u8> {
    list.iter().position(|p| p.valid && p.id == id).map(|n| n as u8)
}

/// Sends a PDO frame on `id`: `held` data, else `map` packed from the dictionary.
#[inline(never)]
fn send(ctx: &mut Context, id: CanId, map: &Mapping, held: Option<[u8; 8]>) {
    let data = match held {
        Some(data) => data,
        None => packed(&ctx.od, map),
    };
    ctx.out.send(Frame { id, rtr: false, len: map.len, data });
}

/// The identifier a PDO or SYNC COB-ID names, if well-formed: 11-bit with bits 11..28 clear,
/// or (where `extended` is allowed) 29-bit; never a CiA 301 restricted identifier.
fn checked_id(value: u32, extended: bool) -> Result<CanId, Abort> {
    if value & COB_EXTENDED != 0 {
        if !extended {
            return Err(Abort::INVALID_VALUE);
        }
    } else if value & 0x1FFF_F800 != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    let id = CanId::from_cob_id(value);
    if id.is_restricted() {
        return Err(Abort::INVALID_VALUE);
    }
    Ok(id)
}

/// The rules every PDO COB-ID write follows (D-PDO-2): PRE-OPERATIONAL only; 11-bit; bits
/// 0..29 change only while the PDO is invalid; a valid identifier is not restricted.
fn check_cob(nmt: NmtState, old: u32, value: u32, mapped: bool) -> Result<(), Abort> {
    if nmt != NmtState::PreOperational {
        return Err(Abort::DEVICE_STATE);
    }
    if old & COB_INVALID == 0 && (old ^ value) & 0x3FFF_FFFF != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    if value & COB_EXTENDED != 0 || value & 0x1FFF_F800 != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    if value & COB_INVALID == 0 {
        checked_id(value, false)?;
        if !mapped {
            return Err(Abort::INCOMPATIBLE);
        }
    }
    Ok(())
}

/// Transmission types a TPDO accepts (D-PDO-3): an asynchronous TPDO (writable event timer)
/// FDh, FEh, FFh; a synchronous one 1..=240 (every n-th SYNC), FCh and FDh (RTR only).
pub fn tpdo_type_allowed(asynchronous: bool, ttype: u8) -> bool {
    if asynchronous {
        matches!(ttype, TYPE_RTR | TYPE_ASYNC_MANUF | TYPE_ASYNC_PROFILE)
    } else {
        matches!(ttype, 1..=240 | TYPE_SYNC_RTR | TYPE_RTR)
    }
}

/// Transmission types an RPDO accepts (CiA 301, AP10T 1400h.02): 0..=240 synchronous,
/// FEh and FFh asynchronous.
pub fn rpdo_type_allowed(ttype: u8) -> bool {
    matches!(ttype, 0..=240 | TYPE_ASYNC_MANUF | TYPE_ASYNC_PROFILE)
}

/// Resolves mapping record `index` with `count` objects (its sub 0, or the value written
/// there) against the dictionary, into `map`; on `Err`, `map` maps nothing and is not `ok`.
fn resolve(od: &Od, index: u16, count: u8, rx: bool, map: &mut Mapping) -> Result<(), Abort> {
    map.count = 0;
    map.len = 0;
    map.ok = false;
    if count as usize > MAX_MAPPED || (count > 0 && od.pos(index, count).is_none()) {
        return Err(Abort::INVALID_VALUE);
    }
    let mut len = 0u8;
    for sub in 1..=count {
        let value = od.value(index, sub).ok_or(Abort::INVALID_VALUE)?;
        let (pos, bytes) = slice(od, value, rx)?;
        map.slices[(sub - 1) as usize % MAX_MAPPED] = Slice { pos, at: len };
        len += bytes;
        if len > 8 {
            return Err(Abort::PDO_LENGTH);
        }
    }
    map.count = count;
    map.len = len;
    map.ok = true;
    Ok(())
}

/// One mapping entry (index << 16 | sub << 8 | bits) resolved: a PDO-mappable entry of at
/// least that many bits (whole bytes), or, in an RPDO, a CiA 301 dummy (a data type index
/// 0001h..0007h, sub 0): its dictionary position ([`NONE`] for a dummy) and its bytes.
fn slice(od: &Od, value: u32, rx: bool) -> Result<(u8, u8), Abort> {
    let (index, sub, bits) = ((value >> 16) as u16, (value >> 8) as u8, value as u8);
    if bits == 0 || bits % 8 != 0 || bits > 32 {
        return Err(Abort::NOT_MAPPABLE);
    }
    let bytes = bits / 8;
    if rx && (0x0001..=0x0007).contains(&index) && sub == 0 {
        // Bytes of the type, a nibble each from 0001h: BOOLEAN, INTEGER8 1; INTEGER16 2;
        // INTEGER32 4; UNSIGNED8 1; UNSIGNED16 2; UNSIGNED32 4.
        let size = (0x4214_2110u32 >> (4 * index)) as u8 & 0xF;
        return if bytes == size { Ok((NONE, bytes)) } else { Err(Abort::NOT_MAPPABLE) };
    }
    let pos = od.find(index, sub)?;
    let e = od.entry(pos);
    if !e.pdo || bits > e.dtype.bits() {
        return Err(Abort::NOT_MAPPABLE);
    }
    Ok((pos as u8, bytes))
}

/// [`pack`], not inlined: for every sender but the SYNC's transmissions.
#[inline(never)]
fn packed(od: &Od, map: &Mapping) -> [u8; 8] {
    pack(od, map)
}

/// A TPDO's payload: each mapped value's low bytes, little-endian, in mapping order.
#[inline(always)]
fn pack(od: &Od, map: &Mapping) -> [u8; 8] {
    // Every value is written as four bytes at its place, resolved with the mapping: the bytes
    // past a value's length are overwritten by the next value or cleared below. A mapping
    // holds at most 8 bytes, so every value starts at 0..=7 and the payload ends at 0..=8;
    // the buffer has room for a value at any place below 16 (what a mask gives without a
    // compare).
    let mut buf = [0u8; 19];
    for s in map.slices() {
        let v = od.get(s.pos as usize).to_le_bytes();
        let i = s.at as usize % 16;
        buf[i] = v[0];
        buf[i + 1] = v[1];
        buf[i + 2] = v[2];
        buf[i + 3] = v[3];
    }
    // Bytes past the payload are zero (`Frame::data` contract): the last value's bytes past
    // the payload's end (at most three) are cleared, the rest were never written. The
    // mapping's length is at most 8.
    let end = map.len as usize % 16;
    buf[end] = 0;
    buf[end + 1] = 0;
    buf[end + 2] = 0;
    buf[end + 3] = 0;
    [buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], buf[6], buf[7]]
}

/// Writes an RPDO's payload into its mapped entries, after checking every value against the
/// entry's limits (and 0/1 for BOOLEAN); a payload with any value out of range is discarded
/// whole (D-PDO-6). Returns whether it was written.
fn apply(od: &mut Od, map: &Mapping, data: &[u8; 8]) -> bool {
    let mut values = [0u32; MAX_MAPPED];
    let word = u64::from_le_bytes(*data);
    // From the last slice back: each one's bytes run to where the one after it starts.
    let mut end = map.len as u32;
    for (k, s) in map.slices().iter().enumerate().rev() {
        let at = s.at as u32;
        let n = end - at;
        end = at;
        // The slice's bytes, zero-extended (a mapping holds at most 8 bytes: `at` <= 7).
        let mut v = (word >> (8 * (at % 8))) as u32 & (u32::MAX >> (32 - 8 * n));
        if s.pos == NONE {
            continue;
        }
        let e = od.entry(s.pos as usize);
        // The value as a number: an unsigned one as received (it fits its type, which is at
        // least as long as the mapping), a signed one sign-extended from its mapped bytes.
        let mut x = v as i64;
        if e.dtype.is_signed() {
            // A signed object mapped shorter than its type: sign-extended within the type.
            let shift = 32 - 8 * n;
            let signed = (v << shift) as i32 >> shift;
            x = signed as i64;
            v = signed as u32 & (u32::MAX >> (32 - 8 * e.dtype.size() as u32));
        }
        if let Some((lo, hi)) = e.limits() {
            if x < lo || x > hi {
                return false;
            }
        }
        if e.dtype == DataType::Boolean && v > 1 {
            return false;
        }
        values[k] = v;
    }
    for (k, s) in map.slices().iter().enumerate() {
        if s.pos != NONE {
            od.set(s.pos as usize, values[k]);
        }
    }
    true
}

#[cfg(test)]
mod tests;
