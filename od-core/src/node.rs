//! A CANopen node: the dictionary, the services and the device, driven by frames and time.
//!
//! The shell (firmware, host test, simulator) feeds it with [`Node::on_frame`] and
//! [`Node::poll`], performs the [`Output`]s it takes from [`Node::next_output`], and sleeps
//! until [`Node::next_deadline`]. The node never waits, never reads a clock and keeps no
//! global state.

use crate::abort::Abort;
use crate::autobaud::Scan;
use crate::bitrate::Bitrate;
use crate::emcy::{self, Emcy};
use crate::frame::{CanId, Frame, RxId};
use crate::guarding::{self, Guarding};
use crate::heartbeat::{self, Heartbeat};
use crate::lss::{self, Lss, LssEvent};
use crate::nmt::{NmtCommand, NmtRequest, NmtState};
use crate::od::{CoreHook, Default as OdDefault, Entry, Group, GroupMask, Hook, Od};
use crate::pdo::{self, PdoEvent, Pdos};
use crate::sdo::{ObjectAccess, SdoServer, Written};
use crate::storage::{self, Image, Loaded, Record, Storage};
use crate::time::{earliest, Instant};

/// Something the shell must do for the node.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Output {
    /// Put this frame on the bus.
    Frame(Frame),
    /// Persist the current values of these parameter groups, then report the result with
    /// [`Node::store_done`].
    Store(GroupMask),
    /// Switch the CAN controller to this bit rate now (the node sends and receives nothing
    /// meanwhile).
    SetBitrate(Bitrate),
}

/// How many outputs may wait for the shell. A node produces at most a handful per frame
/// or tick; the shell drains the queue after each call.
pub const OUTBOX_DEPTH: usize = 32;

/// Most frame kinds [`Node::rx_ids`] lists: LSS, NMT, SDO, guarding and SYNC, two for each of
/// up to [`pdo::MAX_RPDOS`] RPDOs and one for each TPDO.
pub const MAX_RX_IDS: usize = 5 + 2 * pdo::MAX_RPDOS + pdo::MAX_TPDOS;

/// Outputs waiting for the shell.
#[derive(Clone, Default)]
pub struct Outbox {
    q: heapless::Deque<Output, OUTBOX_DEPTH>,
}

impl Outbox {
    /// Queues an output. When the shell has not drained the queue the oldest frame is kept
    /// and the new one dropped, as a full CAN transmit mailbox would.
    pub fn push(&mut self, out: Output) {
        let _ = self.q.push_back(out);
    }

    /// Queues a frame.
    pub fn send(&mut self, frame: Frame) {
        self.push(Output::Frame(frame));
    }

    /// Takes the oldest output.
    pub fn pop(&mut self) -> Option<Output> {
        self.q.pop_front()
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}

/// Which reset the node performs (NMT 81h / 82h, power-on).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ResetKind {
    /// Power-on or NMT Reset Node (81h): application and communication re-initialised.
    Node,
    /// NMT Reset Communication (82h): communication re-initialised only.
    Communication,
}

/// What the CAN controller reports besides frames. The shell passes each change it sees to
/// [`Node::on_bus_event`]; the device turns them into its diagnosis objects and EMCYs (5000h,
/// 1002h, 8120h, 8140h as its manual says).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum BusEvent {
    /// The controller entered the error-passive state (an error counter above 127).
    ErrorPassive,
    /// The controller is error active again (both error counters back below 128).
    ErrorActive,
    /// The controller went bus-off (transmit error counter above 255); it sends nothing.
    BusOff,
    /// The controller recovered from bus-off (128 × 11 recessive bits) and is error active.
    BusOffRecovered,
    /// A received frame was lost because the receive FIFO was full.
    RxOverrun,
    /// The controller detected a protocol error of this kind (its last error code).
    ProtocolError(CanError),
    /// The controller's current error counters (for 1002h), reported when they change.
    ErrorCounters {
        /// Receive error counter.
        rx: u8,
        /// Transmit error counter.
        tx: u8,
    },
}

/// The kind of a CAN protocol error (ISO 11898-1), as controllers report it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CanError {
    /// Bit stuffing violated.
    Stuff,
    /// A fixed-form field held an illegal bit.
    Form,
    /// No node acknowledged a transmitted frame.
    Acknowledge,
    /// A transmitted bit read back different (recessive or dominant).
    Bit,
    /// The received CRC did not match.
    Crc,
}

/// The node's state that every service and the device may touch: the dictionary, the NMT
/// state, the active node-ID and bit rate, and the output queue.
pub struct Core {
    /// Object dictionary.
    pub od: Od,
    /// NMT state.
    pub nmt: NmtState,
    /// Active node-ID (1..=127), or 255 while unconfigured (LSS only).
    pub node_id: u8,
    /// Active bit rate.
    pub bitrate: Bitrate,
    /// Outputs for the shell.
    pub out: Outbox,
    /// EMCY producer and error history.
    pub emcy: Emcy,
    /// Heartbeat producer.
    pub heartbeat: Heartbeat,
    /// Node and life guarding.
    pub guarding: Guarding,
    /// SYNC consumer and PDOs.
    pub pdo: Pdos,
    /// LSS slave.
    pub lss: Lss,
    /// Stored parameters: what an NMT reset loads, pending restores and saves.
    pub storage: Storage,
}

impl Core {
    /// Does the node take part in CANopen (has a valid node-ID)?
    pub fn configured(&self) -> bool {
        (1..=127).contains(&self.node_id)
    }
}

/// What a device asks of its node beyond frames and stores, taken by the node after the
/// device ran ([`Device::take_requests`]): the AP10T's Auto-ID answers its deferred SDO write
/// after a key press and then runs the initialisation again with the new node-ID.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct DeviceRequests {
    /// Answer the SDO request the device deferred ([`Device::on_write_deferred`]).
    pub sdo: Option<Result<(), Abort>>,
    /// Reset this way (after the SDO answer).
    pub reset: Option<ResetKind>,
    /// Leave OPERATIONAL for PRE-OPERATIONAL, as an NMT 80h would (the AP10T's external
    /// heartbeat ran out).
    pub pre_operational: bool,
}

/// What a device (a CiA 406 encoder, the AP10T display ...) adds to the core.
pub trait Device {
    /// The device's dictionary, sorted by (index, sub).
    fn table(&self) -> &'static [Entry];

    /// The coding of the pending bit-rate entry (hooked `PendingBitrate`) as (code, rate).
    fn bitrate_codes(&self) -> &'static [(u32, Bitrate)] {
        crate::bitrate::SIKO_CODES
    }

    /// Does a 1011h restore of `groups` set entry `e` back to its default? By default the
    /// entries of those storage groups (1011h sub 2, 3, 4 = index ranges 1000h-1FFFh,
    /// 6000h-9FFFh, 2000h-5FFFh). A device whose manual lists other entries overrides it (the
    /// AP10T's "bus parameters", manual Table 4). Factory data is never restored.
    fn restores(&self, e: &Entry, groups: GroupMask) -> bool {
        groups.contains(e.group)
    }

    /// Checks and applies a write to an entry whose hook is `Hook::Device(_)`. Called after
    /// the type, access and limit checks; on `Ok` the core stores `value`.
    fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let _ = (core, pos, value, now);
        Ok(())
    }

    /// [`Device::on_write`] for a write whose SDO answer may wait: `Written::Deferred` holds
    /// the answer until the device asks for it ([`DeviceRequests::sdo`]). By default the write
    /// is answered at once.
    fn on_write_deferred(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<Written, Abort> {
        self.on_write(core, pos, value, now).map(|()| Written::Done)
    }

    /// What the device asks of the node now (taken: a second call returns none).
    fn take_requests(&mut self) -> DeviceRequests {
        DeviceRequests::default()
    }

    /// Whether the device has requests waiting (the node polls at once then).
    fn has_requests(&self) -> bool {
        false
    }

    /// The NMT state changed by an NMT command (`core.nmt` is the new state).
    fn on_nmt(&mut self, core: &mut Core, now: Instant) {
        let _ = (core, now);
    }

    /// A receive PDO (0-based number `n`) has written its mapped entries.
    fn on_rpdo(&mut self, core: &mut Core, n: u8, now: Instant) {
        let _ = (core, n, now);
    }

    /// A remote frame asked for receive PDO `n` (0-based) in OPERATIONAL. CiA 301 defines no
    /// answer, so by default there is none; a device whose manual has one (the AP10T returns
    /// its set points) sends it, typically with [`pdo::reply`].
    fn on_rpdo_rtr(&mut self, core: &mut Core, n: u8, now: Instant) {
        let _ = (core, n, now);
    }

    /// A remote frame asked for transmit PDO `n` (0-based) in OPERATIONAL: the answer is its
    /// data ([`pdo::answer_rtr`]), which a device may extend (the AP10T's data identifier,
    /// status word bit 9, is in remote answers only).
    fn on_tpdo_rtr(&mut self, core: &mut Core, n: u8, now: Instant) {
        let _ = now;
        pdo::answer_rtr(core, n);
    }

    /// A SYNC was received in PRE-OPERATIONAL or OPERATIONAL (after the synchronous TPDOs
    /// were sent and the synchronous RPDOs written).
    fn on_sync(&mut self, core: &mut Core, now: Instant) {
        let _ = (core, now);
    }

    /// Called after a reset, with the dictionary already re-initialised.
    fn on_reset(&mut self, core: &mut Core, kind: ResetKind, now: Instant) {
        let _ = (core, kind, now);
    }

    /// Device timers.
    fn poll(&mut self, core: &mut Core, now: Instant) {
        let _ = (core, now);
    }

    /// When the device next needs [`Device::poll`].
    fn next_deadline(&self) -> Option<Instant> {
        None
    }

    /// The CAN controller reported `event` (see [`Node::on_bus_event`]).
    fn on_bus_event(&mut self, core: &mut Core, event: BusEvent, now: Instant) {
        let _ = (core, event, now);
    }

    /// The rates an automatic bit-rate detection tries, in order, when the pending bit-rate
    /// code names no rate at power-on (the AP10T's 5F0Ah.03 = 0, "Auto baud"); empty (the
    /// default): no detection, the node then runs at 500 kbit/s.
    fn auto_bitrates(&self) -> &'static [Bitrate] {
        &[]
    }

    /// Does the SDO server serve expedited transfers only (the AP10T: "exclusively via
    /// expedited Request/Response")? False by default: segmented too.
    fn sdo_expedited_only(&self) -> bool {
        false
    }

    /// Does the device have an LSS slave (CiA 305)? The SGH10, SGH50 and WV5800M do; the
    /// AP10T and the WV58MR have none and return false: their node then ignores 7E5h.
    fn has_lss(&self) -> bool {
        true
    }
}

/// A CANopen node running device `D`.
pub struct Node<D: Device> {
    core: Core,
    device: D,
    sdo: SdoServer,
    /// The automatic bit-rate detection under way (before the boot-up).
    scan: Option<Scan>,
}

impl<D: Device> Node<D> {
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
        node.core.node_id = node_id;
        node.core.bitrate = bitrate;
        if code.is_some() {
            node.scan = None;
        }
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

    fn power_on(device: D, loaded: &Loaded, fallback_node_id: u8) -> Node<D> {
        let (od, storage, node_id) = storage::power_on(device.table(), loaded, fallback_node_id);
        let pending = pending_bitrate(&device, &od);
        let scan = match pending {
            None if storage::pending(&od, CoreHook::PendingBitrate).is_some() => Scan::new(device.auto_bitrates()),
            _ => None,
        };
        let bitrate = pending.or(scan.map(|s| s.rate())).unwrap_or(Bitrate::K500);
        let lss = Lss::new(&od, device.has_lss(), device.bitrate_codes());
        let core = Core {
            od,
            nmt: NmtState::Initialising,
            node_id,
            bitrate,
            out: Outbox::default(),
            emcy: Emcy::default(),
            heartbeat: Heartbeat::default(),
            guarding: Guarding::default(),
            pdo: Pdos::default(),
            lss,
            storage,
        };
        let mut sdo = SdoServer::new();
        sdo.set_expedited_only(device.sdo_expedited_only());
        Node { core, device, sdo, scan }
    }

    /// The shared state.
    pub fn core(&self) -> &Core {
        &self.core
    }

    /// The device.
    pub fn device(&self) -> &D {
        &self.device
    }

    /// The device and the core together, for the shell's sensor samples and key presses.
    pub fn split(&mut self) -> (&mut D, &mut Core) {
        (&mut self.device, &mut self.core)
    }

    /// The NMT state.
    pub fn nmt_state(&self) -> NmtState {
        self.core.nmt
    }

    /// Takes the next thing the shell must do.
    pub fn next_output(&mut self) -> Option<Output> {
        self.core.out.pop()
    }

    /// Is the node detecting its bit rate (before its boot-up)? The shell then runs its CAN
    /// controller silent (it sends nothing, not even an ACK or an error frame), at the rate
    /// the last `Output::SetBitrate` named, with its acceptance filters open, and passes every
    /// frame received without error: the first one ends the detection (D-AP-20).
    pub fn listen_only(&self) -> bool {
        self.scan.is_some()
    }

    /// Handles one received frame.
    pub fn on_frame(&mut self, frame: &Frame, now: Instant) {
        // A frame received without error during the bit-rate detection proves the rate: the
        // node takes it (as its pending code, which a 1010h save keeps) and boots up.
        if let Some(scan) = self.scan.take() {
            let rate = scan.rate();
            self.core.bitrate = rate;
            let code = self.device.bitrate_codes().iter().find(|(_, b)| *b == rate).map(|(c, _)| *c);
            if let (Some(pos), Some(code)) = (self.core.od.find_hook(CoreHook::PendingBitrate), code) {
                self.core.od.set(pos, code);
            }
            return;
        }
        // LSS works in every NMT state and without a node-ID (CiA 305).
        if frame.id == CanId::Std(lss::RX_ID) && self.core.lss.enabled() {
            let event = lss::on_frame(&mut self.core, frame, now);
            self.on_lss(event, now);
            return;
        }
        // An LSS bit-rate switch sets INITIALISATION: nothing else is handled until boot-up.
        if !self.core.configured() || self.core.nmt == NmtState::Initialising {
            return;
        }
        let id = self.core.node_id as u16;
        match frame.id {
            CanId::Std(0) => {
                if let Some(req) = NmtRequest::parse(frame) {
                    if req.addresses(self.core.node_id) {
                        self.on_nmt(req.command, now);
                    }
                }
            }
            CanId::Std(x) if x == 0x600 + id => {
                if !frame.rtr && self.core.nmt.sdo_allowed() {
                    let Node { core, device, sdo, .. } = self;
                    let response = sdo.on_request(frame.payload(), now, &mut Dict { core, device });
                    self.send_sdo(response);
                }
            }
            CanId::Std(x) if x == 0x700 + id => {
                if frame.rtr {
                    guarding::on_rtr(&mut self.core, frame, now);
                }
            }
            _ => match pdo::on_frame(&mut self.core, frame, now) {
                PdoEvent::None => {}
                PdoEvent::Rtr(n) => self.device.on_tpdo_rtr(&mut self.core, n, now),
                PdoEvent::Sync { rpdos } => {
                    for n in 0..pdo::MAX_RPDOS as u8 {
                        if rpdos & (1 << n) != 0 {
                            self.device.on_rpdo(&mut self.core, n, now);
                        }
                    }
                    self.device.on_sync(&mut self.core, now);
                }
                PdoEvent::Rpdo(n) => self.device.on_rpdo(&mut self.core, n, now),
                PdoEvent::RpdoRtr(n) => self.device.on_rpdo_rtr(&mut self.core, n, now),
            },
        }
    }

    /// The CAN controller reported `event`: the device keeps its diagnosis (5000h, 1002h) and
    /// raises or clears its EMCYs. EMCYs raised while the node cannot send (bus-off, STOPPED)
    /// follow the EMCY producer's rules.
    pub fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.device.on_bus_event(&mut self.core, event, now);
    }

    /// Runs the timers due at `now`.
    pub fn poll(&mut self, now: Instant) {
        if let Some(scan) = &mut self.scan {
            let first = scan.next_deadline() == Instant::ZERO;
            if let Some(rate) = scan.poll(now).or(first.then(|| scan.rate())) {
                self.core.bitrate = rate;
                self.core.out.push(Output::SetBitrate(rate));
            }
            // The device runs meanwhile (the AP10T's display test), off the bus.
            self.device.poll(&mut self.core, now);
            return;
        }
        let event = lss::poll(&mut self.core, now);
        self.on_lss(event, now);
        if !self.core.configured() || self.core.lss.switching() {
            return;
        }
        if self.core.nmt == NmtState::Initialising {
            self.boot_up(now);
        }
        let timeout = self.sdo.poll(now);
        self.send_sdo(timeout);
        heartbeat::poll(&mut self.core, now);
        guarding::poll(&mut self.core, now);
        emcy::poll(&mut self.core, now);
        pdo::poll(&mut self.core, now);
        self.device.poll(&mut self.core, now);
        self.device_requests(now);
    }

    /// Carries out what the device asked for: the deferred SDO answer first (on the identifier
    /// in use when it was asked), then the reset.
    fn device_requests(&mut self, now: Instant) {
        let req = self.device.take_requests();
        if let Some(result) = req.sdo {
            let response = self.sdo.complete_deferred(result);
            self.send_sdo(response);
        }
        if req.pre_operational && self.core.nmt == NmtState::Operational {
            self.on_nmt(NmtCommand::EnterPreOperational, now);
        }
        if let Some(kind) = req.reset {
            self.reset(kind, now);
        }
    }

    /// When [`Node::poll`] must next run; `None` when nothing is scheduled.
    pub fn next_deadline(&self) -> Option<Instant> {
        if let Some(scan) = &self.scan {
            return Some(scan.next_deadline());
        }
        let core = &self.core;
        let mut next = lss::next_deadline(core);
        if core.lss.switching() {
            return next;
        }
        if self.device.has_requests() {
            return Some(Instant::ZERO);
        }
        if core.configured() {
            if core.nmt == NmtState::Initialising {
                return Some(Instant::ZERO);
            }
            next = earliest(next, self.sdo.next_deadline());
            next = earliest(next, heartbeat::next_deadline(core));
            next = earliest(next, guarding::next_deadline(core));
            next = earliest(next, pdo::next_deadline(core));
        }
        earliest(next, self.device.next_deadline())
    }

    /// Every frame the node acts on, in some state, for the shell's acceptance filters: LSS
    /// 7E5h (if the device has LSS) and, with a node-ID, NMT 000h, the SDO request 600h +
    /// node-ID, the node-guarding remote frame 700h + node-ID, SYNC (1005h), the valid RPDOs
    /// (data and remote) and the valid TPDOs that accept a remote request (remote). Without
    /// duplicates; frames of any other kind the node ignores, so a filter that passes exactly
    /// these loses nothing. It changes only when [`Node::rx_ids_generation`] does.
    pub fn rx_ids(&self) -> heapless::Vec<RxId, MAX_RX_IDS> {
        let mut ids = heapless::Vec::new();
        let core = &self.core;
        if core.lss.enabled() {
            let _ = ids.push(RxId::data(CanId::Std(lss::RX_ID)));
        }
        if core.configured() {
            let id = core.node_id as u16;
            let _ = ids.push(RxId::data(CanId::Std(0x000)));
            let _ = ids.push(RxId::data(CanId::Std(0x600 + id)));
            let _ = ids.push(RxId::remote(CanId::Std(0x700 + id)));
            core.pdo.rx_ids(&mut ids);
        }
        ids
    }

    /// A number that changes whenever [`Node::rx_ids`] may have changed (node-ID, 1005h, PDO
    /// COB-IDs, every reset): the shell reprograms its filters when it sees a new one.
    pub fn rx_ids_generation(&self) -> u32 {
        self.core.pdo.generation()
    }

    /// The shell has finished (or failed) the [`Output::Store`] it was given.
    /// The result goes to whoever asked: LSS store configuration, else the SDO server (1010h).
    pub fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        storage::store_done(&mut self.core, result.is_ok(), now);
        if lss::store_done(&mut self.core, result.is_ok()) {
            return;
        }
        let response = self.sdo.complete_deferred(result.map_err(|()| Abort::CANNOT_STORE));
        self.send_sdo(response);
    }

    fn send_sdo(&mut self, response: Option<[u8; 8]>) {
        if let Some(data) = response {
            self.core.out.send(Frame::std(0x580 + self.core.node_id as u16, &data));
        }
    }

    fn on_lss(&mut self, event: LssEvent, now: Instant) {
        match event {
            LssEvent::None => {}
            LssEvent::ResetCommunication => self.reset(ResetKind::Communication, now),
            // Communication restarts on the new bit rate: `poll` sends the boot-up next.
            LssEvent::BootUp => {
                self.core.nmt = NmtState::Initialising;
                self.sdo.reset();
            }
        }
    }

    fn on_nmt(&mut self, command: NmtCommand, now: Instant) {
        let state = &mut self.core.nmt;
        match command {
            NmtCommand::Start => *state = NmtState::Operational,
            NmtCommand::Stop => {
                *state = NmtState::Stopped;
                self.sdo.reset();
            }
            NmtCommand::EnterPreOperational => *state = NmtState::PreOperational,
            NmtCommand::ResetNode => self.reset(ResetKind::Node, now),
            NmtCommand::ResetCommunication => self.reset(ResetKind::Communication, now),
        }
        pdo::on_state(&mut self.core, now);
        self.device.on_nmt(&mut self.core, now);
    }

    fn reset(&mut self, kind: ResetKind, now: Instant) {
        self.core.nmt = NmtState::Initialising;
        self.sdo.reset();
        let device = &self.device;
        storage::reload(&mut self.core, kind, |e, groups| device.restores(e, groups));
        self.activate_pending();
        sdo_cob_ids(&mut self.core);
        // The reloaded PDO configuration and node-ID count from now (filters, caches).
        pdo::reset(&mut self.core, now);
        lss::reset(&mut self.core);
        self.device.on_reset(&mut self.core, kind, now);
        // After the device has re-evaluated its conditions on the reloaded dictionary: the
        // EMCYs announced after the boot-up are the conditions that still hold, not a stale
        // code and its 0000h for one the reset removed (issue 13 point 14, D-EMCY-8).
        emcy::reset(&mut self.core);
    }

    /// A reset activates the pending node-ID and bit rate (5F0Ah and alike, set by SDO or
    /// LSS). Node-ID FFh is LSS "unconfigured": the node then answers LSS only.
    fn activate_pending(&mut self) {
        if let Some(id) = storage::pending(&self.core.od, CoreHook::PendingNodeId) {
            if (1..=127).contains(&id) || id == lss::UNCONFIGURED as u32 {
                self.core.node_id = id as u8;
            }
        }
        if let Some(rate) = pending_bitrate(&self.device, &self.core.od) {
            // A rate LSS configured waits for activate bit timing or a power cycle (D-LSS-15).
            if rate != self.core.bitrate && !lss::rate_awaits_activation(&self.core) {
                self.core.bitrate = rate;
                self.core.out.push(Output::SetBitrate(rate));
            }
        }
    }

    fn boot_up(&mut self, now: Instant) {
        self.core.out.send(Frame::std(0x700 + self.core.node_id as u16, &[0x00]));
        self.core.nmt = NmtState::PreOperational;
        heartbeat::reset(&mut self.core, now);
        guarding::reset(&mut self.core);
        pdo::reset(&mut self.core, now);
        storage::boot_up(&mut self.core, now);
    }
}

/// Sets the entries that no parameter group stores and whose default is "base + node-ID" to
/// that default for the active node-ID: 1200h sub 1/2, the read-only SDO COB-IDs ("600h +
/// Node-ID", "580h + Node-ID"), always name the identifiers the SDO server uses, also after a
/// reset that activated a new node-ID (issue 13 point 8, D-SDO-7). Stored COB-IDs (1014h,
/// PDOs) follow the node-ID through `storage::reload` instead.
fn sdo_cob_ids(core: &mut Core) {
    let id = core.node_id;
    for (pos, e) in core.od.table().iter().enumerate() {
        if e.group == Group::None && matches!(e.default, OdDefault::PlusNodeId(_)) {
            core.od.set(pos, e.default_value(id));
        }
    }
}

/// The bit rate the pending bit-rate entry selects, if the device has one that codes a rate.
fn pending_bitrate<D: Device>(device: &D, od: &Od) -> Option<Bitrate> {
    let code = storage::pending(od, CoreHook::PendingBitrate)?;
    device.bitrate_codes().iter().find(|(c, _)| *c == code).map(|(_, b)| *b)
}

/// The dictionary as the SDO server sees it: checks, hooks, then the value.
struct Dict<'a, D: Device> {
    core: &'a mut Core,
    device: &'a mut D,
}

impl<D: Device> ObjectAccess for Dict<'_, D> {
    fn read_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
        let pos = self.core.od.find(index, sub)?;
        self.core.od.check_read(pos)?;
        emcy::check_read(self.core, index, sub)?;
        Ok(self.core.od.entry(pos).size())
    }

    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
        let pos = self.core.od.find(index, sub)?;
        self.core.od.check_read(pos)?;
        emcy::check_read(self.core, index, sub)?;
        Ok(self.core.od.encode(pos, buf))
    }

    fn write_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
        let pos = self.core.od.find(index, sub)?;
        Ok(self.core.od.entry(pos).size())
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort> {
        let pos = self.core.od.find(index, sub)?;
        let value = self.core.od.check_write(pos, data)?;
        let hook = self.core.od.entry(pos).hook;
        let written = match hook {
            Hook::None => Written::Done,
            Hook::Core(hook) => core_write(self.core, hook, pos, value, now)?,
            Hook::Device(_) => self.device.on_write_deferred(self.core, pos, value, now)?,
        };
        // 1010h/1011h signatures are commands: the entries keep reading their capabilities.
        if !matches!(hook, Hook::Core(CoreHook::Store | CoreHook::Restore)) {
            self.core.od.set(pos, value);
        }
        Ok(written)
    }
}

/// Checks a write to an entry with a core hook and applies its side effect. On `Ok` the
/// caller stores the value (except the 1010h/1011h commands). Each service owns its rules.
fn core_write(core: &mut Core, hook: CoreHook, pos: usize, value: u32, now: Instant) -> Result<Written, Abort> {
    match hook {
        CoreHook::Store => storage::on_store(core, pos, value),
        CoreHook::Restore => storage::on_restore(core, pos, value),
        CoreHook::ErrorHistory | CoreHook::EmcyCobId => {
            emcy::on_write(core, hook, pos, value, now).map(|()| Written::Done)
        }
        CoreHook::Guarding => guarding::on_write(core, pos, value, now).map(|()| Written::Done),
        CoreHook::HeartbeatTime => heartbeat::on_write(core, value, now).map(|()| Written::Done),
        CoreHook::SyncCobId
        | CoreHook::PdoCobId
        | CoreHook::PdoTransmissionType
        | CoreHook::PdoEventTimer
        | CoreHook::PdoMapping => pdo::on_write(core, hook, pos, value, now).map(|()| Written::Done),
        // 5F0Ah and alike hold the pending node-ID and bit-rate code: storing the value (its
        // range is the entry's limits) is the whole write; the next reset activates it.
        CoreHook::PendingNodeId => Ok(Written::Done),
        CoreHook::PendingBitrate => {
            // An SDO-written rate is adopted at the next reset, also over an LSS-configured one.
            lss::rate_written(core);
            Ok(Written::Done)
        }
    }
}
