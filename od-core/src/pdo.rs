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
use crate::time::Instant;

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
    /// Bytes in the PDO (1..=4).
    bytes: u8,
}

impl Slice {
    const EMPTY: Slice = Slice { pos: NONE, bytes: 0 };
}

/// A PDO's mapping resolved against the dictionary.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Mapping {
    slices: [Slice; MAX_MAPPED],
    count: u8,
    /// Payload length in bytes.
    len: u8,
    /// False when the stored mapping names no valid object: the PDO is not used.
    ok: bool,
}

impl Mapping {
    const EMPTY: Mapping = Mapping { slices: [Slice::EMPTY; MAX_MAPPED], count: 0, len: 0, ok: false };

    fn slices(&self) -> &[Slice] {
        &self.slices[..self.count as usize]
    }
}

/// Dictionary positions of one PDO's parameters.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Params {
    /// Communication record index (1400h + n, 1800h + n).
    comm: u16,
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
    const EMPTY: Params = Params { comm: 0, cob: NONE, ttype: NONE, inhibit: NONE, event: NONE, asynchronous: false };

    fn load(od: &Od, comm: u16) -> Option<Params> {
        let at = |sub| od.pos(comm, sub).map_or(NONE, |p| p as u8);
        let cob = od.pos(comm, 1)? as u8;
        let event = at(5);
        let asynchronous = event != NONE && od.entry(event as usize).access.writable();
        Some(Params { comm, cob, ttype: at(2), inhibit: at(3), event, asynchronous })
    }

    fn get(od: &Od, pos: u8, default: u32) -> u32 {
        if pos == NONE {
            default
        } else {
            od.get(pos as usize)
        }
    }
}

/// A transmit PDO.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Tpdo {
    params: Params,
    map: Mapping,
    id: CanId,
    valid: bool,
    rtr: bool,
    ttype: u8,
    /// SYNCs counted towards the next transmission (types 1..=240).
    count: u8,
    /// Next event-timer transmission (types FEh/FFh with a non-zero event timer).
    next: Option<Instant>,
    /// Last event-driven transmission (for the inhibit time).
    last: Option<Instant>,
    /// Data sampled at the last SYNC (type FCh).
    sample: Option<[u8; 8]>,
}

impl Tpdo {
    const EMPTY: Tpdo = Tpdo {
        params: Params::EMPTY,
        map: Mapping::EMPTY,
        id: CanId::Std(0),
        valid: false,
        rtr: false,
        ttype: 0,
        count: 0,
        next: None,
        last: None,
        sample: None,
    };

    fn event_driven(&self) -> bool {
        matches!(self.ttype, TYPE_ASYNC_MANUF | TYPE_ASYNC_PROFILE)
    }
}

/// A receive PDO.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Rpdo {
    params: Params,
    map: Mapping,
    id: CanId,
    valid: bool,
    ttype: u8,
    /// Data received for a synchronous RPDO, written at the next SYNC.
    pending: Option<[u8; 8]>,
}

impl Rpdo {
    const EMPTY: Rpdo =
        Rpdo { params: Params::EMPTY, map: Mapping::EMPTY, id: CanId::Std(0), valid: false, ttype: 0, pending: None };
}

/// PDO and SYNC state: the resolved configuration, counters and timers.
#[derive(Clone)]
pub struct Pdos {
    /// [`CanId::key`] of the SYNC identifier (1005h), `u32::MAX` when the node consumes no
    /// SYNC: one compare per frame ([`Pdos::is_sync`]).
    sync_key: u32,
    /// The TPDOs a SYNC concerns (valid, mapped, type 1..=240 or FCh), one bit each: a SYNC
    /// visits only them. Kept by [`Pdos::reset`] and [`Pdos::on_write`], which alone change
    /// those three.
    sync_tx: u8,
    tpdo: [Tpdo; MAX_TPDOS],
    ntpdo: u8,
    rpdo: [Rpdo; MAX_RPDOS],
    nrpdo: u8,
    /// The node is OPERATIONAL and the PDOs run.
    running: bool,
    /// Earliest event-timer transmission.
    deadline: Option<Instant>,
    /// Changes with every identifier the node listens to.
    generation: u32,
}

impl Default for Pdos {
    fn default() -> Pdos {
        Pdos {
            sync_key: u32::MAX,
            sync_tx: 0,
            tpdo: [Tpdo::EMPTY; MAX_TPDOS],
            ntpdo: 0,
            rpdo: [Rpdo::EMPTY; MAX_RPDOS],
            nrpdo: 0,
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
        for r in self.rpdos().iter().filter(|r| r.valid) {
            push(RxId::data(r.id));
            push(RxId::remote(r.id));
        }
        for t in self.tpdos().iter().filter(|t| t.valid && t.rtr) {
            push(RxId::remote(t.id));
        }
    }

    fn refresh_sync_tx(&mut self) {
        let mut mask = 0;
        for (n, t) in self.tpdos().iter().enumerate() {
            if t.valid && t.map.ok && matches!(t.ttype, 1..=240 | TYPE_SYNC_RTR) {
                mask |= 1 << n;
            }
        }
        self.sync_tx = mask;
    }

    fn set_sync(&mut self, id: Option<CanId>) {
        self.sync_key = id.map_or(u32::MAX, CanId::key);
    }

    /// Is `frame` a SYNC (a data frame on the 1005h identifier)?
    #[inline(always)]
    pub fn is_sync(&self, frame: &Frame) -> bool {
        frame.id.key() == self.sync_key && !frame.rtr
    }

    /// The SYNC identifier (1005h), if the node has one.
    #[inline]
    pub fn sync_id(&self) -> Option<CanId> {
        CanId::from_key(self.sync_key)
    }

    fn tpdos(&self) -> &[Tpdo] {
        &self.tpdo[..self.ntpdo as usize]
    }

    fn rpdos(&self) -> &[Rpdo] {
        &self.rpdo[..self.nrpdo as usize]
    }

    fn update_deadline(&mut self) {
        self.deadline =
            if self.running { self.tpdo[..self.ntpdo as usize].iter().filter_map(|t| t.next).min() } else { None };
    }
}

impl Pdos {
    /// Re-reads the PDO configuration from the dictionary (boot-up after power-on and every NMT
    /// reset). The node is PRE-OPERATIONAL: nothing runs, SYNC counters start from zero.
    pub fn reset(&mut self, od: &Od, now: Instant) {
        let _ = now;
        let p = &mut *self;
        let generation = p.generation.wrapping_add(1);
        *p = Pdos { generation, ..Pdos::default() };
        p.set_sync(od.pos(0x1005, 0).map(|pos| CanId::from_cob_id(od.get(pos))));
        for n in 0..MAX_TPDOS as u16 {
            let Some(params) = Params::load(od, 0x1800 + n) else { break };
            let cob = od.get(params.cob as usize);
            let map = resolve(od, 0x1A00 + n, None, false).unwrap_or(Mapping::EMPTY);
            let t = &mut p.tpdo[n as usize];
            *t = Tpdo {
                params,
                map,
                ttype: Params::get(od, params.ttype, TYPE_ASYNC_PROFILE as u32) as u8,
                ..Tpdo::EMPTY
            };
            set_tpdo_cob(t, cob);
            p.ntpdo += 1;
        }
        for n in 0..MAX_RPDOS as u16 {
            let Some(params) = Params::load(od, 0x1400 + n) else { break };
            let cob = od.get(params.cob as usize);
            let map = resolve(od, 0x1600 + n, None, true).unwrap_or(Mapping::EMPTY);
            let r = &mut p.rpdo[n as usize];
            *r = Rpdo {
                params,
                map,
                ttype: Params::get(od, params.ttype, TYPE_ASYNC_PROFILE as u32) as u8,
                ..Rpdo::EMPTY
            };
            set_rpdo_cob(r, cob);
            p.nrpdo += 1;
        }
        p.refresh_sync_tx();
    }

    /// Starts or stops the PDOs after an NMT state change: entering OPERATIONAL restarts the SYNC
    /// counters and the event timers (first transmission one period later); leaving it stops
    /// everything and drops synchronous RPDO data not yet applied.
    pub fn on_state(&mut self, od: &Od, nmt: NmtState, now: Instant) {
        let operational = nmt == NmtState::Operational;
        let p = &mut *self;
        if operational == p.running {
            return;
        }
        p.running = operational;
        for t in p.tpdo[..p.ntpdo as usize].iter_mut() {
            t.count = 0;
            t.sample = None;
            t.last = None;
            t.next = if operational { first_event(od, t, now) } else { None };
        }
        for r in p.rpdo[..p.nrpdo as usize].iter_mut() {
            r.pending = None;
        }
        p.update_deadline();
    }

    /// Handles a frame that may be a SYNC, an RPDO or a PDO remote request.
    pub fn on_frame(&mut self, ctx: &mut Context, nmt: NmtState, frame: &Frame, now: Instant) -> PdoEvent {
        if self.is_sync(frame) {
            return self.on_sync(ctx, nmt);
        }
        if !self.running {
            return PdoEvent::None;
        }
        let p = &mut *self;
        if frame.rtr {
            for n in 0..p.ntpdo as usize {
                let t = &p.tpdo[n];
                if t.valid && t.id == frame.id {
                    if !t.rtr || !t.map.ok {
                        return PdoEvent::None;
                    }
                    return PdoEvent::Rtr(n as u8);
                }
            }
            for n in 0..p.nrpdo as usize {
                let r = &p.rpdo[n];
                if r.valid && r.id == frame.id {
                    return PdoEvent::RpdoRtr(n as u8);
                }
            }
            return PdoEvent::None;
        }
        for n in 0..p.nrpdo as usize {
            let r = &mut p.rpdo[n];
            if !(r.valid && r.id == frame.id) {
                continue;
            }
            // CiA 301: fewer bytes than mapped → not processed; more → the first ones are used.
            if !r.map.ok || frame.len < r.map.len {
                return PdoEvent::None;
            }
            if r.ttype <= 240 {
                r.pending = Some(frame.data);
                return PdoEvent::None;
            }
            let map = r.map;
            return if apply(&mut ctx.od, &map, &frame.data) { PdoEvent::Rpdo(n as u8) } else { PdoEvent::None };
        }
        let _ = now;
        PdoEvent::None
    }

    /// Handles a SYNC (the caller has matched the frame with [`Pdos::sync_id`]): sends the
    /// synchronous TPDOs that are due and applies the synchronous RPDOs received;
    /// [`PdoEvent::Sync`] names them, or [`PdoEvent::None`] when the node ignores SYNC (STOPPED).
    #[inline(always)]
    pub fn on_sync(&mut self, ctx: &mut Context, nmt: NmtState) -> PdoEvent {
        let p = &mut *self;
        if !p.running {
            // PRE-OPERATIONAL consumes SYNC (the device may use it); STOPPED does not.
            return if nmt == NmtState::PreOperational { PdoEvent::Sync { rpdos: 0 } } else { PdoEvent::None };
        }
        let mut due = p.sync_tx;
        while due != 0 {
            let t = &mut p.tpdo[due.trailing_zeros() as usize];
            due &= due - 1;
            match t.ttype {
                1..=240 => {
                    t.count += 1;
                    if t.count >= t.ttype {
                        t.count = 0;
                        let data = pack(&ctx.od, &t.map);
                        ctx.out.send(Frame { id: t.id, rtr: false, len: t.map.len, data });
                    }
                }
                TYPE_SYNC_RTR => t.sample = Some(pack(&ctx.od, &t.map)),
                _ => {}
            }
        }
        let rpdos = if p.nrpdo == 0 { 0 } else { p.apply_pending(&mut ctx.od) };
        PdoEvent::Sync { rpdos }
    }

    /// Applies the synchronous RPDO data received since the last SYNC; the RPDOs written, one
    /// bit each.
    #[inline(never)]
    fn apply_pending(&mut self, od: &mut Od) -> u8 {
        let mut rpdos = 0;
        for n in 0..self.nrpdo as usize {
            if let Some(data) = self.rpdo[n].pending.take() {
                let map = self.rpdo[n].map;
                if apply(od, &map, &data) {
                    rpdos |= 1 << n;
                }
            }
        }
        rpdos
    }

    /// Sends the event-timer TPDOs that are due.
    pub fn poll(&mut self, ctx: &mut Context, now: Instant) {
        let p = &mut *self;
        if !p.running || p.deadline.is_none_or(|d| d > now) {
            return;
        }
        for t in p.tpdo[..p.ntpdo as usize].iter_mut() {
            let Some(due) = t.next else { continue };
            if due > now {
                continue;
            }
            // The inhibit time (100 µs units) holds the transmission back, if declared.
            let inhibit = Params::get(&ctx.od, t.params.inhibit, 0) as u64 * 100;
            if let Some(last) = t.last {
                let free = last.add_micros(inhibit);
                if inhibit > 0 && free > now {
                    t.next = Some(free);
                    continue;
                }
            }
            if t.valid && t.map.ok {
                let data = pack(&ctx.od, &t.map);
                ctx.out.send(Frame { id: t.id, rtr: false, len: t.map.len, data });
                t.last = Some(now);
            }
            // A changed event timer takes effect now, at the timer's next operation (manuals).
            let period = Params::get(&ctx.od, t.params.event, 0) as u64;
            t.next = match period {
                0 => None,
                ms => {
                    let next = due.add_millis(ms);
                    Some(if next > now { next } else { now.add_millis(ms) })
                }
            };
        }
        p.update_deadline();
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
        self.reply_inner(ctx, rpdo, tpdo)
    }

    /// Answers a remote request for TPDO `n` ([`PdoEvent::Rtr`]): the data sampled at the
    /// last SYNC (type FCh) or else its current data, on its identifier.
    pub fn answer_rtr(&self, ctx: &mut Context, n: u8) {
        let Some(t) = self.tpdos().get(n as usize) else { return };
        if !t.valid || !t.map.ok {
            return;
        }
        let data = t.sample.unwrap_or_else(|| pack(&ctx.od, &t.map));
        ctx.out.send(Frame { id: t.id, rtr: false, len: t.map.len, data });
    }

    fn reply_inner(&self, ctx: &mut Context, rpdo: u8, tpdo: u8) {
        let p = self;
        let (Some(r), Some(t)) = (p.rpdos().get(rpdo as usize), p.tpdos().get(tpdo as usize)) else { return };
        if !p.running || !r.valid || !t.map.ok {
            return;
        }
        let frame = Frame { id: r.id, rtr: false, len: t.map.len, data: pack(&ctx.od, &t.map) };
        ctx.out.send(frame);
    }

    /// Sets the event timer (18xxh.05) of TPDO `n` (0-based) to `ms`, with the checks and timing
    /// of an SDO write: for a device whose own entry mirrors it (the encoders' 6200h cycle timer).
    pub fn set_event_timer(&mut self, ctx: &mut Context, n: u8, ms: u16, now: Instant) -> Result<(), Abort> {
        let params = self.tpdos().get(n as usize).map(|t| t.params).filter(|p| p.event != NONE);
        let params = params.ok_or(Abort::NO_OBJECT)?;
        if !params.asynchronous {
            return Err(Abort::READ_ONLY);
        }
        let pos = params.event as usize;
        self.write_event_timer(n as usize, ms as u32, now)?;
        ctx.od.set(pos, ms as u32);
        Ok(())
    }

    /// Checks a write to 1005h or a PDO parameter (entry `pos`, rule `hook`) and applies it to the
    /// running PDOs; on `Ok` the node stores the value.
    pub fn on_write(
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
        let result = match hook {
            CoreHook::SyncCobId => self.write_sync(nmt, value),
            CoreHook::PdoCobId => match pdo_of(index) {
                Some((Dir::Tx, n)) if n < self.ntpdo as usize => self.write_tpdo_cob(ctx, nmt, n, value, now),
                Some((Dir::Rx, n)) if n < self.nrpdo as usize => self.write_rpdo_cob(ctx, nmt, n, value),
                _ => Err(Abort::UNSUPPORTED_ACCESS),
            },
            CoreHook::PdoTransmissionType => match pdo_of(index) {
                Some((Dir::Tx, n)) if n < self.ntpdo as usize => self.write_tpdo_type(&ctx.od, n, value, now),
                Some((Dir::Rx, n)) if n < self.nrpdo as usize => self.write_rpdo_type(n, value),
                _ => Err(Abort::UNSUPPORTED_ACCESS),
            },
            CoreHook::PdoEventTimer => match pdo_of(index) {
                Some((Dir::Tx, n)) if n < self.ntpdo as usize && sub == 5 => self.write_event_timer(n, value, now),
                // RPDO deadline monitoring is not supported (no manual has it).
                _ => Err(Abort::UNSUPPORTED_ACCESS),
            },
            CoreHook::PdoMapping => match map_of(index) {
                Some((Dir::Tx, n)) if n < self.ntpdo as usize => self.write_mapping(ctx, nmt, Dir::Tx, n, sub, value),
                Some((Dir::Rx, n)) if n < self.nrpdo as usize => self.write_mapping(ctx, nmt, Dir::Rx, n, sub, value),
                _ => Err(Abort::UNSUPPORTED_ACCESS),
            },
            _ => Err(Abort::GENERAL),
        };
        self.refresh_sync_tx();
        result
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
        let id = checked_id(value, true)?;
        if self.sync_id() != Some(id) {
            self.set_sync(Some(id));
            self.touch_rx_ids();
        }
        Ok(())
    }

    fn write_tpdo_cob(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        n: usize,
        value: u32,
        now: Instant,
    ) -> Result<(), Abort> {
        let t = &self.tpdo[n];
        let old = ctx.od.get(t.params.cob as usize);
        check_cob(nmt, old, value, t.map.ok)?;
        let t = &mut self.tpdo[n];
        set_tpdo_cob(t, value);
        t.count = 0;
        t.sample = None;
        t.next = if self.running && t.valid { first_event(&ctx.od, t, now) } else { None };
        self.update_deadline();
        self.touch_rx_ids();
        Ok(())
    }

    fn write_rpdo_cob(&mut self, ctx: &mut Context, nmt: NmtState, n: usize, value: u32) -> Result<(), Abort> {
        let r = &self.rpdo[n];
        let old = ctx.od.get(r.params.cob as usize);
        check_cob(nmt, old, value, r.map.ok)?;
        let r = &mut self.rpdo[n];
        set_rpdo_cob(r, value);
        r.pending = None;
        self.touch_rx_ids();
        Ok(())
    }

    fn write_tpdo_type(&mut self, od: &Od, n: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let t = &mut self.tpdo[n];
        let ttype = u8::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        if !tpdo_type_allowed(t.params.asynchronous, ttype) {
            return Err(Abort::INVALID_VALUE);
        }
        if ttype != t.ttype {
            let was_event = t.event_driven();
            t.ttype = ttype;
            t.count = 0;
            t.sample = None;
            if !t.event_driven() {
                t.next = None;
            } else if !was_event && self.running {
                t.next = first_event(od, t, now);
            }
            self.update_deadline();
        }
        Ok(())
    }

    fn write_rpdo_type(&mut self, n: usize, value: u32) -> Result<(), Abort> {
        let ttype = u8::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        if !rpdo_type_allowed(ttype) {
            return Err(Abort::INVALID_VALUE);
        }
        let r = &mut self.rpdo[n];
        r.ttype = ttype;
        r.pending = None;
        Ok(())
    }

    /// The event timer (D-PDO-4): 0 stops the timer at once; a new period on a running timer
    /// applies from its next expiry (the manuals' "next timer operation"); a stopped timer given a
    /// period starts now and fires one period later.
    fn write_event_timer(&mut self, n: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let ms = u16::try_from(value).map_err(|_| Abort::INVALID_VALUE)?;
        let p = &mut *self;
        let t = &mut p.tpdo[n];
        if ms == 0 {
            t.next = None;
        } else if t.next.is_none() && p.running && t.valid && t.event_driven() {
            t.next = Some(now.add_millis(ms as u64));
        }
        p.update_deadline();
        Ok(())
    }

    /// A mapping write (D-PDO-5): PRE-OPERATIONAL only; only while the PDO is invalid; the
    /// objects (sub 1..) only while sub 0 is 0; sub 0 = n checks the n objects and their total
    /// length, and makes the mapping the PDO's.
    fn write_mapping(
        &mut self,
        ctx: &mut Context,
        nmt: NmtState,
        dir: Dir,
        n: usize,
        sub: u8,
        value: u32,
    ) -> Result<(), Abort> {
        if nmt != NmtState::PreOperational {
            return Err(Abort::DEVICE_STATE);
        }
        let (valid, index) = match dir {
            Dir::Tx => (self.tpdo[n].valid, 0x1A00 + n as u16),
            Dir::Rx => (self.rpdo[n].valid, 0x1600 + n as u16),
        };
        if valid {
            return Err(Abort::INVALID_VALUE);
        }
        let rx = dir == Dir::Rx;
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
        let map = resolve(&ctx.od, index, Some(count), rx)?;
        match dir {
            Dir::Tx => self.tpdo[n].map = map,
            Dir::Rx => self.rpdo[n].map = map,
        }
        Ok(())
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Dir {
    Tx,
    Rx,
}

/// Which PDO a communication record index belongs to.
fn pdo_of(index: u16) -> Option<(Dir, usize)> {
    match index {
        0x1400..=0x15FF => Some((Dir::Rx, (index - 0x1400) as usize)),
        0x1800..=0x19FF => Some((Dir::Tx, (index - 0x1800) as usize)),
        _ => None,
    }
}

/// Which PDO a mapping record index belongs to.
fn map_of(index: u16) -> Option<(Dir, usize)> {
    match index {
        0x1600..=0x17FF => Some((Dir::Rx, (index - 0x1600) as usize)),
        0x1A00..=0x1BFF => Some((Dir::Tx, (index - 0x1A00) as usize)),
        _ => None,
    }
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

fn set_tpdo_cob(t: &mut Tpdo, cob: u32) {
    t.id = CanId::from_cob_id(cob);
    t.valid = cob & COB_INVALID == 0;
    t.rtr = cob & COB_NO_RTR == 0;
}

fn set_rpdo_cob(r: &mut Rpdo, cob: u32) {
    r.id = CanId::from_cob_id(cob);
    r.valid = cob & COB_INVALID == 0;
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

/// The first event-timer transmission of a TPDO started at `now`.
fn first_event(od: &Od, t: &Tpdo, now: Instant) -> Option<Instant> {
    let ms = Params::get(od, t.params.event, 0);
    (t.valid && t.event_driven() && ms != 0).then(|| now.add_millis(ms as u64))
}

/// Resolves mapping record `index` (its sub 0, or `count` in its place) against the
/// dictionary.
fn resolve(od: &Od, index: u16, count: Option<u8>, rx: bool) -> Result<Mapping, Abort> {
    let count = match count {
        Some(c) => c,
        None => od.value(index, 0).ok_or(Abort::NO_OBJECT)? as u8,
    };
    if count as usize > MAX_MAPPED || (count > 0 && od.pos(index, count).is_none()) {
        return Err(Abort::INVALID_VALUE);
    }
    let mut map = Mapping { ok: true, ..Mapping::EMPTY };
    let mut bits = 0u32;
    for sub in 1..=count {
        let value = od.value(index, sub).ok_or(Abort::INVALID_VALUE)?;
        let s = slice(od, value, rx)?;
        bits += s.bytes as u32 * 8;
        if bits > 64 {
            return Err(Abort::PDO_LENGTH);
        }
        map.slices[map.count as usize] = s;
        map.count += 1;
    }
    map.len = (bits / 8) as u8;
    Ok(map)
}

/// One mapping entry (index << 16 | sub << 8 | bits) resolved: a PDO-mappable entry of at
/// least that many bits (whole bytes), or, in an RPDO, a CiA 301 dummy (a data type index
/// 0001h..0007h, sub 0).
fn slice(od: &Od, value: u32, rx: bool) -> Result<Slice, Abort> {
    let (index, sub, bits) = ((value >> 16) as u16, (value >> 8) as u8, value as u8);
    if bits == 0 || bits % 8 != 0 || bits > 32 {
        return Err(Abort::NOT_MAPPABLE);
    }
    if rx && (0x0001..=0x0007).contains(&index) && sub == 0 {
        let dummy = match index {
            0x0001 | 0x0002 | 0x0005 => 8,
            0x0003 | 0x0006 => 16,
            _ => 32,
        };
        return if bits == dummy { Ok(Slice { pos: NONE, bytes: bits / 8 }) } else { Err(Abort::NOT_MAPPABLE) };
    }
    let pos = od.find(index, sub)?;
    let e = od.entry(pos);
    if !e.pdo || bits > e.dtype.bits() {
        return Err(Abort::NOT_MAPPABLE);
    }
    Ok(Slice { pos: pos as u8, bytes: bits / 8 })
}

/// A TPDO's payload: each mapped value's low bytes, little-endian, in mapping order.
#[inline]
fn pack(od: &Od, map: &Mapping) -> [u8; 8] {
    // Every value is written as four bytes and the cursor moves by its mapped length: fixed
    // size copies, no call, and the bytes past the mapping are overwritten or cut off.
    let mut buf = [0u8; 12];
    let mut at = 0usize;
    for s in map.slices() {
        let v = od.get(s.pos as usize).to_le_bytes();
        if let Some(dst) = buf.get_mut(at..at + 4) {
            dst.copy_from_slice(&v);
        }
        at += s.bytes as usize;
    }
    let mut data = [0u8; 8];
    data.copy_from_slice(&buf[..8]);
    // Bytes past the payload are zero (`Frame::data` contract).
    let keep = if map.len >= 8 { u64::MAX } else { (1u64 << (8 * map.len)) - 1 };
    (u64::from_le_bytes(data) & keep).to_le_bytes()
}

/// Writes an RPDO's payload into its mapped entries, after checking every value against the
/// entry's limits (and 0/1 for BOOLEAN); a payload with any value out of range is discarded
/// whole (D-PDO-6). Returns whether it was written.
fn apply(od: &mut Od, map: &Mapping, data: &[u8; 8]) -> bool {
    let mut values = [0u32; MAX_MAPPED];
    let mut at = 0usize;
    for (k, s) in map.slices().iter().enumerate() {
        let n = s.bytes as usize;
        let mut raw = [0u8; 4];
        raw[..n].copy_from_slice(&data[at..at + n]);
        at += n;
        if s.pos == NONE {
            continue;
        }
        let e = od.entry(s.pos as usize);
        let mut v = u32::from_le_bytes(raw);
        let size = e.dtype.size();
        if n < size && e.dtype.is_signed() && raw[n - 1] & 0x80 != 0 {
            // A signed object mapped shorter than its type: sign-extend within the type.
            v |= !0u32 << (n * 8);
            if size < 4 {
                v &= (1u32 << (size * 8)) - 1;
            }
        }
        if let Some((lo, hi)) = e.limits() {
            let x = e.dtype.to_i64(v);
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
