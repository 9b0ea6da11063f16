//! A CANopen node: the context, the CANopen services and the device, driven by frames and
//! time.
//!
//! The node owns the transport-neutral [`Context`] (dictionary, outbox, storage, error
//! conditions) and the state of each CANopen service (NMT, SDO server, EMCY producer,
//! heartbeat, guarding, SYNC/PDOs, LSS), and hands each service the context and the facts it
//! needs from the others per call: every dependency between services is visible here. The
//! shell drives it through [`Station`]. The node never waits, never reads a clock and keeps
//! no global state.

use crate::abort::Abort;
use crate::access::{self, Access, Services};
use crate::autobaud::Scan;
use crate::bitrate::Bitrate;
use crate::context::Written;
use crate::device::pending_bitrate;
use crate::emcy;
use crate::frame::{CanId, Frame, RxFilter, RxId};
use crate::guarding::Guarding;
use crate::heartbeat::{send_error_control, Heartbeat};
use crate::lss::{self, Lss, LssEvent};
use crate::nmt::{NmtCommand, NmtRequest, NmtState};
use crate::od::{CoreHook, Group, Hook, Od};
use crate::pdo::{self, PdoEvent, Pdos, RtrAnswer, RtrReply};
use crate::sdo::SdoServer;
use crate::shell::{DeviceStation, Station};
use crate::storage::{self, Image, Loaded, Record, Storage};
use crate::time::{earliest, Due, Instant};
use crate::wire::nmt::{self as nmt_wire, ErrorControl};

/// The context under its former name.
pub use crate::context::Context as Core;
pub use crate::context::{BusEvent, CanError, Context, Outbox, Output, ResetKind, OUTBOX_DEPTH};
pub use crate::device::{CanopenDevice, CanopenStatus, Device, DeviceRequests, Link};
pub use crate::shell::{RxIds, MAX_RX_IDS};

/// A CANopen node running device `D`.
pub struct Node<D: CanopenDevice> {
    ctx: Context,
    device: D,
    nmt: NmtState,
    sdo: SdoServer,
    heartbeat: Heartbeat,
    guarding: Guarding,
    pdo: Pdos,
    lss: Lss,
    /// The automatic bit-rate detection under way (before the boot-up).
    scan: Option<Scan>,
    /// The receive list as a quick filter, and the [`Node::rx_ids_generation`] it was built
    /// for (rebuilt on the first frame after a change).
    filter: (RxFilter, u32),
    /// The SYNC's [`CanId::key`] when [`Node::dispatch`] would hand a data frame on it to
    /// [`Node::on_sync`] (the node has a node-ID, is not initialising, and no other service of
    /// the node takes that identifier), else `u32::MAX` (no identifier): [`Node::on_frame`]
    /// takes such a SYNC straight there. Rebuilt with the filter, which every NMT state change
    /// marks stale.
    sync_key: u32,
    /// [`Node::next_deadline`] as the last poll left it, while nothing else has touched the
    /// node since (`None`: something has, compute it afresh). A poll before it has nothing to
    /// do (issue 14's W4, the firmware's idle tick).
    due: Due,
}

/// The CANopen services whose rules the dictionary access path applies to their entries,
/// with the NMT state they judge by.
struct CanopenServices<'a> {
    nmt: NmtState,
    heartbeat: &'a mut Heartbeat,
    guarding: &'a mut Guarding,
    pdo: &'a mut Pdos,
    lss: &'a mut Lss,
}

impl Services for CanopenServices<'_> {
    #[inline(always)]
    fn write(
        &mut self,
        ctx: &mut Context,
        hook: CoreHook,
        pos: usize,
        value: u32,
        now: Instant,
    ) -> Result<Written, Abort> {
        match hook {
            CoreHook::EmcyCobId => emcy::on_write_cob_id(&ctx.od, self.nmt, pos, value)?,
            CoreHook::Guarding => self.guarding.on_write(ctx.od.entry(pos).index, value, now)?,
            CoreHook::HeartbeatTime => {
                self.heartbeat.on_write(value, now)?;
                // One error-control protocol at a time (CiA 301).
                if self.heartbeat.active() {
                    self.guarding.suspend();
                }
            }
            CoreHook::SyncCobId
            | CoreHook::PdoCobId
            | CoreHook::PdoTransmissionType
            | CoreHook::PdoEventTimer
            | CoreHook::PdoMapping => self.pdo.on_write(ctx, self.nmt, hook, pos, value, now)?,
            // The access path applies the context's own hooks.
            CoreHook::Store
            | CoreHook::Restore
            | CoreHook::ErrorHistory
            | CoreHook::PendingNodeId
            | CoreHook::PendingBitrate => return Err(Abort::GENERAL),
        }
        Ok(Written::Done)
    }

    fn pending_bitrate_written(&mut self) {
        // An SDO-written rate is adopted at the next reset, also over an LSS-configured one.
        self.lss.rate_written();
    }
}

impl<D: CanopenDevice> Node<D> {
    /// A node that has just been powered on with `node_id` and `bitrate` configured and stored
    /// before (in the pending node-ID and bit-rate entries) and every other parameter at its
    /// default: [`Node::boot`] from an image holding just those two.
    pub fn new(device: D, node_id: u8, bitrate: Bitrate) -> Node<D> {
        let mut image = Image::new();
        let code = device.bitrate_codes().iter().find(|(_, b)| *b == bitrate).map(|(c, _)| *c);
        for e in device.table() {
            let value = match e.hook {
                Hook::Core(CoreHook::PendingNodeId) => Some(node_id as u32),
                Hook::Core(CoreHook::PendingBitrate) => code,
                _ => None,
            };
            if let Some(v) = value {
                let _ = image.set(Record::of(e, v));
            }
        }
        let mut node = Node::power_on(device, &Loaded::Image(image), node_id);
        node.ctx.node_id = node_id;
        node.ctx.bitrate = bitrate;
        if code.is_some() {
            node.scan = None;
        }
        node.rebuild_filter();
        node
    }

    /// A node that has just been powered on: INITIALISATION, with the dictionary as the
    /// parameter flash held it (`storage::ParamFlash::load`). The active node-ID and bit rate
    /// are the stored pending ones (their defaults if none are stored; 500 kbit/s if the code
    /// names no rate, such as automatic detection, which the shell then handles); an invalid
    /// flash is reported by EMCY after the boot-up message. The boot-up frame goes out on the
    /// first [`Node::poll`].
    pub fn boot(device: D, loaded: &Loaded) -> Node<D> {
        Node::power_on(device, loaded, 0xFF)
    }

    #[inline(never)]
    fn power_on(device: D, loaded: &Loaded, fallback_node_id: u8) -> Node<D> {
        // Built where it lives: the dictionary and the storage are filled in place
        // (`storage::power_on_in`), not assembled in locals and copied into the node.
        let od = Od::blank(device.table(), device.factory_node_id());
        let lss = Lss::new(&od, device.has_lss(), device.bitrate_codes());
        let mut node = Node {
            ctx: Context::new(od, Storage::empty(loaded), 0, Bitrate::K500),
            device,
            nmt: NmtState::Initialising,
            sdo: SdoServer::new(),
            heartbeat: Heartbeat::default(),
            guarding: Guarding::default(),
            pdo: fresh(),
            lss,
            scan: None,
            filter: (RxFilter::OPEN, 0),
            sync_key: u32::MAX,
            due: Due::default(),
        };
        let ctx = &mut node.ctx;
        ctx.node_id = storage::power_on_in(&mut ctx.od, &mut ctx.storage, loaded, fallback_node_id);
        let device = &node.device;
        let pending = pending_bitrate(device, &ctx.od);
        let scan = match pending {
            None if storage::pending(&ctx.od, CoreHook::PendingBitrate).is_some() => Scan::new(device.auto_bitrates()),
            _ => None,
        };
        ctx.bitrate = pending.or(scan.map(|s| s.rate())).unwrap_or(Bitrate::K500);
        node.scan = scan;
        node.sdo.set_expedited_only(device.sdo_expedited_only());
        node.ctx.errors.announce_with(emcy::frame);
        node.ctx.errors.set_gate(emcy::gate(NmtState::Initialising));
        node.rebuild_filter();
        node.notify();
        node
    }

    /// The shared state.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The shared state (the former name of [`Node::context`]).
    pub fn core(&self) -> &Context {
        &self.ctx
    }

    /// The device.
    pub fn device(&self) -> &D {
        &self.device
    }

    /// The device and the context together, for the shell's sensor samples and key presses.
    pub fn split(&mut self) -> (&mut D, &mut Context) {
        self.due.forget();
        (&mut self.device, &mut self.ctx)
    }

    /// The NMT state.
    pub fn nmt_state(&self) -> NmtState {
        self.nmt
    }

    /// The LSS slave.
    pub fn lss(&self) -> &Lss {
        &self.lss
    }

    /// The heartbeat producer.
    pub fn heartbeat(&self) -> &Heartbeat {
        &self.heartbeat
    }

    /// Node and life guarding.
    pub fn guarding(&self) -> &Guarding {
        &self.guarding
    }

    /// SYNC and the PDOs.
    pub fn pdos(&self) -> &Pdos {
        &self.pdo
    }

    /// What the node's LEDs show.
    pub fn status(&self) -> CanopenStatus {
        CanopenStatus {
            nmt: self.nmt,
            lss_configuration: self.lss.enabled() && self.lss.state() == lss::LssState::Configuration,
            life_guard_event: self.guarding.life_guard_event(),
        }
    }

    /// Tells the device the status its LEDs show.
    #[inline(never)]
    fn notify(&mut self) {
        let status = self.status();
        self.device.on_status(status);
    }

    /// Enters NMT state `state`; error announcements follow it (EMCY rules).
    #[inline(never)]
    fn set_nmt(&mut self, state: NmtState) {
        self.nmt = state;
        // The cached SYNC key follows the state: rebuilt with the filter on the next frame.
        self.filter.1 = !self.rx_ids_generation();
        self.ctx.errors.set_gate(emcy::gate(state));
    }

    /// Takes the next thing the shell must do.
    #[inline]
    pub fn next_output(&mut self) -> Option<Output> {
        self.ctx.out.pop()
    }

    /// Is the node detecting its bit rate (before its boot-up)? The shell then runs its CAN
    /// controller silent (it sends nothing, not even an ACK or an error frame), at the rate
    /// the last `Output::SetBitrate` named, with its acceptance filters open, and passes every
    /// frame received without error: the first one ends the detection (D-AP-20).
    pub fn listen_only(&self) -> bool {
        self.scan.is_some()
    }

    /// Handles one received frame.
    #[inline]
    pub fn on_frame(&mut self, frame: &Frame, now: Instant) {
        // A frame received without error during the bit-rate detection proves the rate.
        if self.scan.is_some() {
            return self.on_scan_frame();
        }
        // Frames for other nodes stop here (the node acts only on its receive list), in a
        // few instructions before the full dispatch's.
        if self.filter.1 != self.rx_ids_generation() {
            self.rebuild_filter();
        }
        if self.filter.0.passes(frame.id) {
            // A SYNC goes straight to its work (issue 14's W3), as the dispatch would route it.
            let key = frame.id.key();
            if key == self.sync_key && !frame.rtr {
                self.due.forget();
                self.on_sync(now);
            } else {
                self.dispatch(frame, key, now);
            }
        }
    }

    /// The bit-rate detection's first frame: the node takes its rate (as its pending code,
    /// which a 1010h save keeps) and boots up.
    #[cold]
    #[inline(never)]
    fn on_scan_frame(&mut self) {
        self.due.forget();
        if let Some(scan) = self.scan.take() {
            let rate = scan.rate();
            self.ctx.bitrate = rate;
            let code = self.device.bitrate_codes().iter().find(|(_, b)| *b == rate).map(|(c, _)| *c);
            if let (Some(pos), Some(code)) = (self.ctx.od.find_hook(CoreHook::PendingBitrate), code) {
                self.ctx.od.set(pos, code);
            }
        }
    }

    #[cold]
    #[inline(never)]
    fn rebuild_filter(&mut self) {
        self.filter = (RxFilter::new(&self.rx_ids()), self.rx_ids_generation());
        // The identifiers `dispatch` tests before the SYNC's take it first.
        let key = self.pdo.sync_key();
        let id = self.ctx.node_id as u32;
        let taken = !self.ctx.configured()
            || self.nmt == NmtState::Initialising
            || (key == lss::RX_ID as u32 && self.lss.enabled())
            || key == 0
            || key == 0x600 + id
            || key == 0x700 + id;
        self.sync_key = if taken { u32::MAX } else { key };
    }

    /// A frame on the receive list (or one the quick filter could not tell from it).
    #[inline(never)]
    fn dispatch(&mut self, frame: &Frame, key: u32, now: Instant) {
        self.due.forget();
        // One number per identifier (`key`, the frame's `CanId::key`): each test below is one
        // compare.
        // LSS works in every NMT state and without a node-ID (CiA 305).
        // `has_lss` first: a device without LSS (the AP10T) keeps no LSS code in this path.
        if key == lss::RX_ID as u32 && self.device.has_lss() && self.lss.enabled() {
            let event = self.lss.on_frame(&mut self.ctx, frame, now);
            self.on_lss(event, now);
            self.notify();
            return;
        }
        // An LSS bit-rate switch sets INITIALISATION: nothing else is handled until boot-up.
        if !self.ctx.configured() || self.nmt == NmtState::Initialising {
            return;
        }
        let id = self.ctx.node_id as u32;
        if key == 0 {
            if let Some(req) = NmtRequest::parse(frame.payload()) {
                if req.addresses(self.ctx.node_id) {
                    self.on_nmt(req.command, now);
                }
            }
        } else if key == 0x600 + id {
            if !frame.rtr && self.nmt.sdo_allowed() {
                let Node { ctx, device, sdo, nmt, heartbeat, guarding, pdo, lss, .. } = self;
                // The device's constant: a device without segmented transfers keeps none here.
                let expedited_only = device.sdo_expedited_only();
                let mut services = CanopenServices { nmt: *nmt, heartbeat, guarding, pdo, lss };
                let mut access = Access { ctx, device, services: &mut services };
                let answer = sdo.on_request_as(expedited_only, frame.payload(), now, &mut access);
                self.send_sdo(answer);
            }
        } else if key == 0x700 + id {
            if frame.rtr {
                self.on_guarding_rtr(now);
            }
        } else {
            // A SYNC never gets here: `on_frame` takes it (`Node::sync_key`, rebuilt with the
            // filter after every change of the node-ID, 1005h or the NMT state).
            debug_assert!(!self.pdo.is_sync(frame), "a SYNC in the dispatch");
            self.on_pdo_frame(frame, now);
        }
    }

    /// A SYNC: the synchronous TPDOs and RPDOs, then the device.
    #[inline(never)]
    fn on_sync(&mut self, now: Instant) {
        if let PdoEvent::Sync { rpdos } = self.pdo.on_sync(&mut self.ctx, self.nmt) {
            for n in 0..pdo::MAX_RPDOS as u8 {
                if rpdos & (1 << n) != 0 {
                    self.device.on_rpdo(&mut self.ctx, n, now);
                }
            }
            self.device.on_sync(&mut self.ctx, now);
        }
    }

    /// An RPDO or a PDO remote request.
    #[inline(never)]
    fn on_pdo_frame(&mut self, frame: &Frame, now: Instant) {
        match self.pdo.on_pdo(&mut self.ctx, frame, now) {
            PdoEvent::None | PdoEvent::Sync { .. } => {}
            PdoEvent::Rtr(n) => {
                let answer = RtrAnswer::new(&self.pdo, n);
                self.device.on_tpdo_rtr(&mut self.ctx, n, &answer, now);
            }
            PdoEvent::Rpdo(n) => self.device.on_rpdo(&mut self.ctx, n, now),
            PdoEvent::RpdoRtr(n) => {
                let reply = RtrReply::new(&self.pdo, n);
                self.device.on_rpdo_rtr(&mut self.ctx, n, &reply, now);
            }
        }
    }

    /// The CAN controller reported `event`: the device keeps its diagnosis (5000h, 1002h) and
    /// raises or clears its EMCYs. EMCYs raised while the node cannot send (bus-off, STOPPED)
    /// follow the EMCY producer's rules.
    pub fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.due.forget();
        self.device.on_bus_event(&mut self.ctx, event, now);
    }

    /// Runs the timers due at `now`.
    #[inline]
    pub fn poll(&mut self, now: Instant) {
        // Nothing has touched the node since the last poll, and its next deadline is later:
        // nothing to do.
        if self.due.nothing_at(now) {
            return;
        }
        self.poll_all(now);
        self.due.remember(self.deadline());
    }

    #[inline(never)]
    fn poll_all(&mut self, now: Instant) {
        if let Some(scan) = &mut self.scan {
            let first = scan.next_deadline() == Instant::ZERO;
            if let Some(rate) = scan.poll(now).or(first.then(|| scan.rate())) {
                self.ctx.bitrate = rate;
                self.ctx.out.push(Output::SetBitrate(rate));
            }
            // The device runs meanwhile (the AP10T's display test), off the bus.
            self.device.poll(&mut self.ctx, now);
            return;
        }
        let event = if self.device.has_lss() { self.lss.poll(&mut self.ctx, now) } else { LssEvent::None };
        if event != LssEvent::None {
            self.on_lss(event, now);
        }
        if !self.ctx.configured() || self.lss.switching() {
            return;
        }
        if self.nmt == NmtState::Initialising {
            self.boot_up(now);
        }
        // Only a segmented transfer times out: none without them (the device's constant).
        if let Some(timeout) = if self.device.sdo_expedited_only() { None } else { self.sdo.poll(now) } {
            self.send_sdo(Some(timeout));
        }
        self.heartbeat.poll(&mut self.ctx.out, self.ctx.node_id, self.nmt, now);
        if self.guarding.poll(now) {
            self.notify();
        }
        self.ctx.release_deferred();
        self.pdo.poll(&mut self.ctx, now);
        self.device.poll(&mut self.ctx, now);
        if self.device.has_requests() {
            self.device_requests(now);
            // A reset the device asked for (the AP10T's Auto-ID) boots up in this poll, as
            // every reset a poll performs does.
            if self.nmt == NmtState::Initialising && self.ctx.configured() && !self.lss.switching() {
                self.boot_up(now);
            }
        }
    }

    /// Carries out what the device asked for: the deferred SDO answer first (on the identifier
    /// in use when it was asked), then the state change or the reset.
    #[cold]
    #[inline(never)]
    fn device_requests(&mut self, now: Instant) {
        let req = self.device.take_requests();
        if let Some(result) = req.sdo {
            let response = self.sdo.complete_deferred(result);
            self.send_sdo(response);
        }
        if req.pre_operational && self.nmt == NmtState::Operational {
            self.on_nmt(NmtCommand::EnterPreOperational, now);
        }
        if let Some(kind) = req.reset {
            self.reset(kind, now);
        }
    }

    /// When [`Node::poll`] must next run; `None` when nothing is scheduled. A poll before it
    /// does nothing.
    #[inline]
    pub fn next_deadline(&self) -> Option<Instant> {
        self.due.get(|| self.deadline())
    }

    #[inline(never)]
    fn deadline(&self) -> Option<Instant> {
        if let Some(scan) = &self.scan {
            // The device runs meanwhile (the AP10T's display test).
            return earliest(Some(scan.next_deadline()), self.device.next_deadline());
        }
        if self.device.has_requests() {
            return Some(Instant::ZERO);
        }
        let mut next = if self.device.has_lss() { self.lss.next_deadline() } else { None };
        if self.lss.switching() {
            return next;
        }
        if self.ctx.configured() {
            if self.nmt == NmtState::Initialising {
                return Some(Instant::ZERO);
            }
            if !self.device.sdo_expedited_only() {
                next = earliest(next, self.sdo.next_deadline());
            }
            next = earliest(next, self.heartbeat.next_deadline());
            next = earliest(next, self.guarding.next_deadline());
            next = earliest(next, self.pdo.next_deadline());
        }
        earliest(next, self.device.next_deadline())
    }

    /// Every frame the node acts on, in some state, for the shell's acceptance filters: LSS
    /// 7E5h (if the device has LSS) and, with a node-ID, NMT 000h, the SDO request 600h +
    /// node-ID, the node-guarding remote frame 700h + node-ID, SYNC (1005h), the valid RPDOs
    /// (data and remote) and the valid TPDOs that accept a remote request (remote). Without
    /// duplicates; frames of any other kind the node ignores, so a filter that passes exactly
    /// these loses nothing. It changes only when [`Node::rx_ids_generation`] does.
    pub fn rx_ids(&self) -> RxIds {
        let mut ids = heapless::Vec::new();
        if self.lss.enabled() {
            let _ = ids.push(RxId::data(CanId::Std(lss::RX_ID)));
        }
        if self.ctx.configured() {
            let id = self.ctx.node_id as u16;
            let _ = ids.push(RxId::data(CanId::Std(0x000)));
            let _ = ids.push(RxId::data(CanId::Std(0x600 + id)));
            let _ = ids.push(RxId::remote(CanId::Std(0x700 + id)));
            self.pdo.rx_ids(&mut ids);
        }
        ids
    }

    /// A number that changes whenever [`Node::rx_ids`] may have changed (node-ID, 1005h, PDO
    /// COB-IDs, every reset): the shell reprograms its filters when it sees a new one.
    pub fn rx_ids_generation(&self) -> u32 {
        self.pdo.generation()
    }

    /// The shell has finished (or failed) the [`Output::Store`] it was given.
    /// The result goes to whoever asked: LSS store configuration, else the SDO server (1010h).
    pub fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.due.forget();
        self.ctx.store_done(result.is_ok(), now);
        if self.device.has_lss() && self.lss.store_done(&mut self.ctx, result.is_ok()) {
            return;
        }
        let response = self.sdo.complete_deferred(result.map_err(|()| Abort::CANNOT_STORE));
        self.send_sdo(response);
    }

    #[inline]
    fn send_sdo(&mut self, response: Option<[u8; 8]>) {
        if let Some(data) = response {
            self.ctx.out.send(Frame::std(0x580 + self.ctx.node_id as u16, &data));
        }
    }

    /// A node-guarding RTR: guarding answers unless the heartbeat runs.
    #[inline(never)]
    fn on_guarding_rtr(&mut self, now: Instant) {
        let heartbeat = self.heartbeat.active();
        if self.guarding.on_rtr(&mut self.ctx.out, self.ctx.node_id, self.nmt, heartbeat, now) {
            self.notify();
        }
    }

    #[cold]
    #[inline(never)]
    fn on_lss(&mut self, event: LssEvent, now: Instant) {
        match event {
            LssEvent::None => {}
            LssEvent::Switching => {
                self.set_nmt(NmtState::Initialising);
                self.notify();
            }
            LssEvent::ResetCommunication => self.reset(ResetKind::Communication, now),
            // Communication restarts on the new bit rate: `poll` sends the boot-up next.
            LssEvent::BootUp => {
                self.set_nmt(NmtState::Initialising);
                self.sdo.reset();
                self.notify();
            }
        }
    }

    fn on_nmt(&mut self, command: NmtCommand, now: Instant) {
        match command {
            NmtCommand::Start => self.set_nmt(NmtState::Operational),
            NmtCommand::Stop => {
                self.set_nmt(NmtState::Stopped);
                self.sdo.reset();
            }
            NmtCommand::EnterPreOperational => self.set_nmt(NmtState::PreOperational),
            NmtCommand::ResetNode => self.reset(ResetKind::Node, now),
            NmtCommand::ResetCommunication => self.reset(ResetKind::Communication, now),
        }
        self.pdo.on_state(&self.ctx.od, self.nmt, now);
        self.notify();
        self.device.on_nmt(&mut self.ctx, self.nmt, now);
    }

    #[cold]
    #[inline(never)]
    fn reset(&mut self, kind: ResetKind, now: Instant) {
        self.set_nmt(NmtState::Initialising);
        self.sdo.reset();
        let device = &self.device;
        self.ctx.reload(kind, |e, groups| device.restores(e, groups));
        self.activate_pending();
        sdo_cob_ids(&mut self.ctx);
        // The reloaded PDO configuration and node-ID count from now (filters, caches).
        self.pdo.reset(&self.ctx.od, now);
        self.lss.reset();
        self.device.on_reset(&mut self.ctx, kind, now);
        // After the device has re-evaluated its conditions on the reloaded dictionary: the
        // EMCYs announced after the boot-up are the conditions that still hold, not a stale
        // code and its 0000h for one the reset removed (issue 13 point 14, D-EMCY-8).
        self.ctx.errors.defer_active();
        self.notify();
    }

    /// A reset activates the pending node-ID and bit rate (5F0Ah and alike, set by SDO or
    /// LSS). Node-ID FFh is LSS "unconfigured": the node then answers LSS only.
    fn activate_pending(&mut self) {
        if let Some(id) = storage::pending(&self.ctx.od, CoreHook::PendingNodeId) {
            if (1..=127).contains(&id) || id == lss::UNCONFIGURED as u32 {
                self.ctx.node_id = id as u8;
            }
        }
        if let Some(rate) = pending_bitrate(&self.device, &self.ctx.od) {
            // A rate LSS configured waits for activate bit timing or a power cycle (D-LSS-15).
            if rate != self.ctx.bitrate && !self.lss.rate_awaits_activation(&self.ctx.od) {
                self.ctx.bitrate = rate;
                self.ctx.out.push(Output::SetBitrate(rate));
            }
        }
    }

    #[cold]
    #[inline(never)]
    fn boot_up(&mut self, now: Instant) {
        let boot_up = ErrorControl { state: nmt_wire::BOOT_UP, toggle: false };
        send_error_control(&mut self.ctx.out, self.ctx.node_id, boot_up);
        self.set_nmt(NmtState::PreOperational);
        self.heartbeat.reset(&self.ctx.od, now);
        self.guarding.reset(&self.ctx.od);
        self.pdo.reset(&self.ctx.od, now);
        self.ctx.boot_up(now);
        self.notify();
    }

    /// Writes `data` to (index, sub) through the dictionary access path, as an SDO download
    /// does (checks, the services' and the device's rules, the value), whatever the NMT state:
    /// for a device's own user interface and for tests. Nothing changes on `Err`. A 1010h save
    /// answers `Written::Deferred` and completes at [`Node::store_done`].
    pub fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort> {
        self.due.forget();
        let Node { ctx, device, nmt, heartbeat, guarding, pdo, lss, .. } = self;
        let mut services = CanopenServices { nmt: *nmt, heartbeat, guarding, pdo, lss };
        access::write(ctx, device, &mut services, index, sub, data, now)
    }

    /// Test access to the parts (a service's state beside the context).
    #[cfg(test)]
    pub(crate) fn parts(&mut self) -> (&mut Context, &mut NmtState, &mut Pdos) {
        self.due.forget();
        self.filter.1 = !self.rx_ids_generation();
        (&mut self.ctx, &mut self.nmt, &mut self.pdo)
    }
}

/// `T::default()` out of line: built straight into the field it goes to, not in a temporary
/// that is then copied (a large default such as the PDOs').
#[inline(never)]
fn fresh<T: Default>() -> T {
    T::default()
}

/// Sets the entries that no parameter group stores and whose default is "base + node-ID" to
/// that default for the active node-ID: 1200h sub 1/2, the read-only SDO COB-IDs ("600h +
/// Node-ID", "580h + Node-ID"), always name the identifiers the SDO server uses, also after a
/// reset that activated a new node-ID (issue 13 point 8, D-SDO-7). Stored COB-IDs (1014h,
/// PDOs) follow the node-ID through the reload instead.
fn sdo_cob_ids(ctx: &mut Context) {
    let id = ctx.node_id;
    for (pos, e) in ctx.od.table().iter().enumerate() {
        if e.group == Group::None && e.is_node_id_relative() {
            ctx.od.set(pos, ctx.od.default_of(e, id));
        }
    }
}

impl<D: CanopenDevice> Station for Node<D> {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        Node::on_frame(self, frame, now)
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        Node::on_bus_event(self, event, now)
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
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        Node::store_done(self, result, now)
    }
    fn rx_ids(&self) -> RxIds {
        Node::rx_ids(self)
    }
    fn rx_ids_generation(&self) -> u32 {
        Node::rx_ids_generation(self)
    }
    fn context(&self) -> &Context {
        &self.ctx
    }
    fn listen_only(&self) -> bool {
        Node::listen_only(self)
    }
}

impl<D: CanopenDevice> DeviceStation for Node<D> {
    type Device = D;
    fn device(&self) -> &D {
        &self.device
    }
    fn split(&mut self) -> (&mut D, &mut Context) {
        Node::split(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::sgh10;

    struct T;
    impl Device for T {
        fn table(&self) -> &'static [crate::od::Entry] {
            sgh10::TABLE
        }
    }
    impl CanopenDevice for T {}

    fn rtr(node: &mut Node<T>, ms: u64) -> Option<u8> {
        node.on_frame(&Frame::remote(CanId::Std(0x701), 1), Instant::from_millis(ms));
        match node.next_output() {
            Some(Output::Frame(f)) => Some(f.data[0]),
            _ => None,
        }
    }

    /// The node passes the heartbeat's state to guarding: one error-control protocol at a time.
    #[test]
    fn heartbeat_excludes_guarding() {
        let mut node = Node::new(T, 1, Bitrate::K500);
        node.poll(Instant::ZERO);
        node.next_output();
        let at = Instant::from_millis;
        node.write(0x100C, 0, &100u16.to_le_bytes(), at(0)).unwrap();
        node.write(0x100D, 0, &[2], at(0)).unwrap();
        assert_eq!(rtr(&mut node, 0), Some(0x7F));
        assert_eq!(node.guarding().next_deadline(), Some(at(200)));
        node.write(0x1017, 0, &1000u16.to_le_bytes(), at(5)).unwrap();
        assert_eq!(node.guarding().next_deadline(), None);
        assert_eq!(rtr(&mut node, 10), None);
        node.write(0x1017, 0, &0u16.to_le_bytes(), at(20)).unwrap();
        assert_eq!(rtr(&mut node, 30), Some(0xFF));
    }

    /// The receive list changes only with its generation, whatever the bus does: the shell's
    /// acceptance filters and the node's own quick filter rely on it. Random sequences of the
    /// frames that move it (NMT resets, LSS node-ID and store, 1005h, PDO COB-IDs with their
    /// valid and RTR bits), on the SGH10 and the AP10T (which has RPDOs).
    #[test]
    fn receive_list_changes_only_with_its_generation() {
        use crate::devices::ap10t::Ap10t;
        fn sdo(node: u8, index: u16, sub: u8, v: u32) -> Frame {
            let [a, b, c, d] = v.to_le_bytes();
            Frame::std(0x600 + node as u16, &[0x23, index as u8, (index >> 8) as u8, sub, a, b, c, d])
        }
        fn frames(node: u8) -> [Frame; 16] {
            [
                Frame::std(0, &[0x01, 0]),
                Frame::std(0, &[0x80, 0]),
                Frame::std(0, &[0x82, node]),
                Frame::std(0, &[0x81, 0]),
                sdo(node, 0x1005, 0, 0x81),
                sdo(node, 0x1005, 0, 0x80),
                sdo(node, 0x1400, 1, 0x8000_0200 + node as u32),
                sdo(node, 0x1400, 1, 0x0000_0200 + node as u32),
                sdo(node, 0x1400, 1, 0x0000_0333),
                sdo(node, 0x1800, 1, 0x8000_0180 + node as u32),
                sdo(node, 0x1800, 1, 0x4000_0180 + node as u32),
                sdo(node, 0x1800, 1, 0x0000_0180 + node as u32),
                Frame::std(0x7E5, &[0x04, 1, 0, 0, 0, 0, 0, 0]),
                Frame::std(0x7E5, &[0x11, 7, 0, 0, 0, 0, 0, 0]),
                Frame::std(0x7E5, &[0x17, 0, 0, 0, 0, 0, 0, 0]),
                Frame::std(0x7E5, &[0x04, 0, 0, 0, 0, 0, 0, 0]),
            ]
        }
        fn run<D: CanopenDevice>(mut node: Node<D>, seed: u32) {
            let mut x = seed;
            let mut t = 0;
            let mut seen = (node.rx_ids_generation(), node.rx_ids());
            let mut changes = 0;
            for _ in 0..3000 {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                let id = if x >> 31 == 0 { node.context().node_id } else { 7 };
                let f = frames(id)[(x >> 16) as usize % 16];
                t += 1 + (x >> 8) as u64 % 50;
                let now = Instant::from_millis(t);
                node.on_frame(&f, now);
                node.poll(now);
                while let Some(out) = node.next_output() {
                    if let Output::Store(_) = out {
                        node.store_done(Ok(()), now);
                    }
                }
                let now_ids = (node.rx_ids_generation(), node.rx_ids());
                if now_ids.0 == seen.0 {
                    assert_eq!(now_ids.1, seen.1, "receive list changed under generation {} after {f:?}", seen.0);
                }
                changes += (now_ids.1 != seen.1) as u32;
                let filter = RxFilter::new(&now_ids.1);
                assert!(now_ids.1.iter().all(|r| filter.passes(r.id)));
                seen = now_ids;
            }
            assert!(changes > 20, "the sequence moved the receive list {changes} times");
        }
        for seed in 0..8 {
            run(Node::new(T, 1, Bitrate::K500), seed);
            run(Node::new(Ap10t::default(), 1, Bitrate::K500), seed);
        }
    }

    /// A poll before the remembered deadline does exactly what a full poll does: nothing. Two
    /// nodes get the same random frames, bus events, sensor samples and polls at random times;
    /// one forgets its deadline before every poll. Their outputs and deadlines never differ.
    #[test]
    fn a_poll_before_the_deadline_is_a_full_poll() {
        use crate::devices::ap10t::Ap10t;
        use crate::devices::sgh10::{Sgh10, Variant};
        use crate::encoder::Encoder;
        fn frame(x: u32, node: u8) -> Frame {
            let n = node as u16;
            let sdo = |cs: u8, index: u16, sub: u8, v: u32| {
                let [a, b, c, d] = v.to_le_bytes();
                Frame::std(0x600 + n, &[cs, index as u8, (index >> 8) as u8, sub, a, b, c, d])
            };
            match x % 14 {
                0 => Frame::std(0, &[0x01, 0]),
                1 => Frame::std(0, &[0x80, 0]),
                2 => Frame::std(0, &[0x81 + (x >> 8) as u8 % 2, node]),
                3 => Frame::std(0x80, &[]),
                4 => Frame::remote(CanId::Std(0x700 + n), 1),
                5 => sdo(0x2B, 0x1017, 0, (x >> 8) % 300),
                6 => sdo(0x2B, 0x100C, 0, (x >> 8) % 300),
                7 => sdo(0x2F, 0x100D, 0, (x >> 8) % 4),
                8 => sdo(0x2B, 0x1800, 5, (x >> 8) % 200),
                9 => sdo(0x2F, 0x1800, 2, [1, 254, 255][(x >> 8) as usize % 3]),
                10 => sdo(0x40, 0x1018, 1, 0),
                11 => sdo(0x23, 0x1010, 1, 0x6576_6173),
                12 => Frame::std(0x200 + n, &[(x >> 8) as u8, (x >> 16) as u8, 0, 0, 0, 0, 0, 0]),
                _ => sdo(0x60, 0, 0, 0),
            }
        }
        fn run<D: CanopenDevice>(make: fn() -> D, sample: fn(&mut D, &mut Context, u32, Instant), seed: u32) {
            let mut a = Node::new(make(), 1, Bitrate::K500);
            let mut b = Node::new(make(), 1, Bitrate::K500);
            let (mut x, mut t) = (seed, 0u64);
            let mut skipped = 0;
            for step in 0..4000 {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                let now = Instant::from_micros(t);
                match (x >> 28) % 8 {
                    0..=2 => {
                        let f = frame(x >> 4, 1);
                        a.on_frame(&f, now);
                        b.on_frame(&f, now);
                    }
                    3 => {
                        let (d, c) = a.split();
                        sample(d, c, x >> 8, now);
                        let (d, c) = b.split();
                        sample(d, c, x >> 8, now);
                    }
                    4 => {
                        let e = [BusEvent::ErrorPassive, BusEvent::ErrorActive, BusEvent::BusOffRecovered]
                            [(x >> 8) as usize % 3];
                        a.on_bus_event(e, now);
                        b.on_bus_event(e, now);
                    }
                    _ => {
                        skipped += a.due.nothing_at(now) as u32;
                        a.poll(now);
                        b.due.forget();
                        b.poll(now);
                    }
                }
                loop {
                    let (oa, ob) = (a.next_output(), b.next_output());
                    assert_eq!(oa, ob, "step {step} at {t} µs");
                    match oa {
                        Some(Output::Store(_)) => {
                            a.store_done(Ok(()), now);
                            b.store_done(Ok(()), now);
                        }
                        Some(_) => {}
                        None => break,
                    }
                }
                assert_eq!(a.next_deadline(), b.deadline(), "step {step} at {t} µs");
                t += [0, 1, 100, 999, 1000, 7_000, 60_000][(x >> 12) as usize % 7];
            }
            assert!(skipped > 100, "{skipped} polls skipped");
        }
        for seed in 0..6 {
            run(|| T, |_, _, _, _| {}, seed);
            let sample = |d: &mut Sgh10, c: &mut Context, raw: u32, now| {
                let raw = if raw.is_multiple_of(4) {
                    Err(crate::encoder::SensorFault::Diagnosis)
                } else {
                    Ok(raw % 3_000_000)
                };
                d.on_sample(c, raw, now)
            };
            run(|| Sgh10::new(Variant::Sgh10), sample, seed);
            run(Ap10t::default, |_, _, _, _| {}, seed);
        }
    }
}
