//! What a device (a CiA 406 encoder, the AP10T display, the J1939 WV58MR ...) adds to a node:
//! its dictionary and its behaviour. [`Device`] is what every transport calls; a CANopen
//! device adds [`CanopenDevice`] (PDOs, SYNC, LSS, the NMT status its LEDs show).

use crate::abort::Abort;
use crate::bitrate::Bitrate;
use crate::context::{BusEvent, Context, ResetKind, Written};
use crate::nmt::NmtState;
use crate::od::{CoreHook, Entry, GroupMask};
use crate::pdo::{RtrAnswer, RtrReply};
use crate::time::Instant;

/// A cross-object link: a write to one of the device's entries is also a write of the same
/// value to entry (`index`, `sub`) under the rules of the transport service that owns `hook`
/// (the encoders' 6200h "cyclic timer" is their TPDO1 event timer 1800h.05 on CANopen; the
/// WV58MR's will be a PGN's repetition rate 3000h.03 on J1939). The dictionary access path
/// applies the linked rule first, stores the value in the linked entry, then calls the device.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Link {
    /// Index of the linked entry.
    pub index: u16,
    /// Sub-index of the linked entry.
    pub sub: u8,
    /// The rule the linked entry's value follows.
    pub hook: CoreHook,
}

/// What a device asks of its node beyond frames and stores, taken by the node after the
/// device ran ([`Device::take_requests`]): the AP10T's Auto-ID answers its deferred SDO write
/// after a key press and then runs the initialisation again with the new node-ID; its external
/// heartbeat sends the node to PRE-OPERATIONAL.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct DeviceRequests {
    /// Answer the SDO request the device deferred ([`Device::on_write_deferred`]).
    pub sdo: Option<Result<(), Abort>>,
    /// Reset this way (after the SDO answer).
    pub reset: Option<ResetKind>,
    /// Leave OPERATIONAL for PRE-OPERATIONAL, as an NMT 80h would.
    pub pre_operational: bool,
}

/// The bit rate the pending bit-rate entry (5F0Ah.02 and alike) selects, if `device` has one
/// that codes a rate: what a node of either transport joins the bus at.
pub(crate) fn pending_bitrate<D: Device>(device: &D, od: &crate::od::Od) -> Option<Bitrate> {
    let code = crate::storage::pending(od, CoreHook::PendingBitrate)?;
    device.bitrate_codes().iter().find(|(c, _)| *c == code).map(|(_, b)| *b)
}

/// The transport-neutral part of a device.
pub trait Device {
    /// The device's dictionary, sorted by (index, sub).
    fn table(&self) -> &'static [Entry];

    /// The node-ID this device variant ships with when it is not the one its table declares:
    /// the default of the entry marked [`crate::od::Entry::factory_node_id`] (what a 1011h
    /// restore and a blank flash give). `None` (the default): the declared one.
    fn factory_node_id(&self) -> Option<u8> {
        None
    }

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

    /// The link a write to entry `e` (hooked `Hook::Device(_)`) carries, if any.
    fn link(&self, e: &Entry) -> Option<Link> {
        let _ = e;
        None
    }

    /// Checks and applies a write to an entry whose hook is `Hook::Device(_)`. Called after
    /// the type, access and limit checks (and the linked rule, [`Device::link`]); on `Ok` the
    /// access path stores `value`.
    fn on_write(&mut self, ctx: &mut Context, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let _ = (ctx, pos, value, now);
        Ok(())
    }

    /// [`Device::on_write`] for a write whose answer may wait: `Written::Deferred` holds the
    /// SDO answer until the device asks for it ([`DeviceRequests::sdo`]). By default the write is
    /// answered at once.
    fn on_write_deferred(&mut self, ctx: &mut Context, pos: usize, value: u32, now: Instant) -> Result<Written, Abort> {
        self.on_write(ctx, pos, value, now).map(|()| Written::Done)
    }

    /// What the device asks of its node now (taken: a second call returns none).
    fn take_requests(&mut self) -> DeviceRequests {
        DeviceRequests::default()
    }

    /// Whether the device has requests waiting (the node then polls at once).
    fn has_requests(&self) -> bool {
        false
    }

    /// Called after a reset, with the dictionary already re-initialised.
    fn on_reset(&mut self, ctx: &mut Context, kind: ResetKind, now: Instant) {
        let _ = (ctx, kind, now);
    }

    /// Device timers.
    fn poll(&mut self, ctx: &mut Context, now: Instant) {
        let _ = (ctx, now);
    }

    /// When the device next needs [`Device::poll`].
    fn next_deadline(&self) -> Option<Instant> {
        None
    }

    /// The CAN controller reported `event` (the node's `on_bus_event`).
    fn on_bus_event(&mut self, ctx: &mut Context, event: BusEvent, now: Instant) {
        let _ = (ctx, event, now);
    }
}

/// What a CANopen node shows its user (CiA 303-3 LEDs): its NMT state, whether LSS holds it
/// in configuration, and a life guarding event.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CanopenStatus {
    /// NMT state.
    pub nmt: NmtState,
    /// The LSS slave is in LSS configuration.
    pub lss_configuration: bool,
    /// A life guarding event happened and no guarding RTR came since.
    pub life_guard_event: bool,
}

impl Default for CanopenStatus {
    fn default() -> Self {
        CanopenStatus { nmt: NmtState::Initialising, lss_configuration: false, life_guard_event: false }
    }
}

/// What a CANopen device adds: PDO and SYNC callbacks, LSS, the NMT status.
pub trait CanopenDevice: Device {
    /// A receive PDO (0-based number `n`) has written its mapped entries.
    fn on_rpdo(&mut self, ctx: &mut Context, n: u8, now: Instant) {
        let _ = (ctx, n, now);
    }

    /// A remote frame asked for receive PDO `n` (0-based) in OPERATIONAL. CiA 301 defines no
    /// answer, so by default there is none; a device whose manual has one (the AP10T returns
    /// its set points) sends a transmit PDO's current data on the RPDO's identifier with
    /// `reply`.
    fn on_rpdo_rtr(&mut self, ctx: &mut Context, n: u8, reply: &RtrReply, now: Instant) {
        let _ = (ctx, n, reply, now);
    }

    /// A remote frame asked for transmit PDO `n` (0-based) in OPERATIONAL: the answer is its
    /// data (`answer`), which a device may extend (the AP10T's data identifier, status word
    /// bit 9, is in remote answers only).
    fn on_tpdo_rtr(&mut self, ctx: &mut Context, n: u8, answer: &RtrAnswer, now: Instant) {
        let _ = (n, now);
        answer.send(ctx);
    }

    /// The NMT state changed by an NMT command or a device request (`nmt` the new state).
    fn on_nmt(&mut self, ctx: &mut Context, nmt: NmtState, now: Instant) {
        let _ = (ctx, nmt, now);
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

    /// A SYNC was received in PRE-OPERATIONAL or OPERATIONAL (after the synchronous TPDOs
    /// were sent and the synchronous RPDOs written).
    fn on_sync(&mut self, ctx: &mut Context, now: Instant) {
        let _ = (ctx, now);
    }

    /// The node's status changed (or may have): what its LEDs show.
    fn on_status(&mut self, status: CanopenStatus) {
        let _ = status;
    }

    /// Does the device have an LSS slave (CiA 305)? The SGH10, SGH50 and WV5800M do; the
    /// AP10T has none and returns false: its node then ignores 7E5h.
    fn has_lss(&self) -> bool {
        true
    }
}
