//! A J1939 node: the transport-neutral [`Context`] (dictionary, outbox, storage, error
//! conditions) and a device, behind the J1939 services: address claiming
//! ([`AddressClaimer`]), the Request responder ([`request`]), the cyclic process-data groups
//! ([`Scheduler`]), parameter access over CAM21/CAM11 through the core's SDO server and the
//! dictionary access path ([`param`], [`crate::access`]), and the EMCY group (PGN 64616). The
//! shell drives it through [`Station`], as it drives a CANopen node.
//!
//! What the node does, in the order the manual's chapters go (the decisions are D-J1939-n in
//! `docs/decisions.md`):
//! - power-on ([`J1939Node::boot`]): the dictionary as the flash held it; the first
//!   [`J1939Node::poll`] starts address claiming at the stored 5F0Ah.01 after the NAME's
//!   pseudo-random delay (D-J1939-13), the green LED blinking;
//! - received frames are parsed as J1939 identifiers (11-bit and remote frames ignored);
//!   Address Claimed and Requests for it go to the claimer at any time, everything else only
//!   once the claim has stood 250 ms ([`AddressClaimer::source_address`]);
//! - once it stood: EPOS, ESPD and Proprietary B at the cycle times and priorities of 3000h
//!   (6200h is 3000h.03), each error condition still active is announced by EMCY, and from then
//!   on every condition that rises (its code) or falls (0000h) once (D-J1939-20);
//! - a CAM21 request to our address is the SDO server's, through the access path; the answer
//!   goes on CAM11 to the requester; a 1010h "save" answers when the shell reports the store
//!   ([`J1939Node::store_done`]); a write to 3000h reaches the scheduler at once; 3002h.01 starts
//!   claiming again, 3002h.02 restarts the node, both after the answer (D-J1939-21);
//! - a Request for EPOS, ESPD or Proprietary B is answered with the group, one for anything
//!   else to our address with a NACK.

use crate::abort::Abort;
use crate::access::{Access, NoServices};
use crate::bitrate::Bitrate;
use crate::context::{BusEvent, Context, Output, ResetKind};
use crate::device::pending_bitrate;
use crate::device::Device;
use crate::errors::Gate;
use crate::frame::{CanId, Frame};
use crate::j1939::claim::{AddressClaimer, State};
use crate::j1939::led::{self, LedInputs};
use crate::j1939::rx::{self, Filter};
use crate::j1939::schedule::{Cyclic, Scheduler};
use crate::j1939::{param, request};
use crate::led::{Leds, WARNING_LIMIT};
use crate::od::{CoreHook, Od};
use crate::sdo::SdoServer;
use crate::shell::{DeviceStation, RxIds, RxMasks, Station};
use crate::storage::{self, Loaded, Storage};
use crate::time::{earliest, Due, Instant};
use crate::wire::j1939::{Address, Emcy, Epos, Espd, Identifier, Name, NameFields, Pgn, Priority, ProprietaryB};

/// The EMCY group's priority (manual §5.6: 1, fixed).
pub const EMCY_PRIORITY: u8 = 1;

/// The groups the node sends and answers Requests for.
pub const PROVIDED: [Pgn; 3] = [Pgn::EPOS, Pgn::ESPD, Pgn::PROPRIETARY_B];

/// The 3000h sub-indices of each provided group: (cycle time, priority).
const PGN_PARAMETERS: [(Pgn, u8, u8); 3] = [(Pgn::PROPRIETARY_B, 1, 4), (Pgn::ESPD, 2, 5), (Pgn::EPOS, 3, 6)];

// `J1939Node::sync_slots` finds slot k's sub-indices at k + 1 and k + 4.
const _: () = {
    let mut k = 0;
    while k < PGN_PARAMETERS.len() {
        assert!(PGN_PARAMETERS[k].1 as usize == k + 1 && PGN_PARAMETERS[k].2 as usize == k + 4);
        k += 1;
    }
};

/// A command a device asks its J1939 node to carry out after the answer to the write that
/// gave it (the WV58MR's 3002h).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Command {
    /// "SAE initialisieren" (3002h.01): claim again, at the 5F0Ah.01 the dictionary holds now;
    /// the dictionary stays.
    InitialiseSae,
    /// "Gerät neu starten" (3002h.02): restart as after power-on (the stored parameters are
    /// loaded, the stored address and bit rate take effect) and claim again.
    Restart,
}

/// What a J1939 node needs from its device beyond [`Device`].
pub trait J1939Device: Device {
    /// The command the last write gave, if any (taken once).
    fn take_command(&mut self) -> Option<Command> {
        None
    }

    /// The 3000h sub-indices whose value the writes since the last call may have changed, as
    /// bits (bit n: 3000h.n; a write of an entry linked to one counts as a write of it), taken
    /// once; the node reads the cyclic groups' cycle times and priorities of those back into
    /// its scheduler after every CAM21 write. The default: all of them.
    fn take_schedule_changes(&mut self) -> u8 {
        u8::MAX
    }

    /// Is the maximum speed exceeded (the yellow LED)?
    fn over_speed(&self) -> bool {
        false
    }

    /// The address claimer's state changed (or may have): what the green LED shows.
    fn on_claim(&mut self, state: State) {
        let _ = state;
    }

    /// The process data the cyclic groups carry: the position value (6004h) and the speed
    /// (6030h.01) as the dictionary holds them (0 where it declares none).
    fn process_data(&self, od: &Od) -> (u32, i16) {
        (od.value(0x6004, 0).unwrap_or(0), od.value(0x6030, 1).unwrap_or(0) as u16 as i16)
    }
}

/// The lowest and highest address the node may claim: the limits of the pending address
/// entry (5F0Ah.01), J1939-81's 128..247 without one.
fn address_range(od: &Od) -> (u8, u8) {
    od.find_hook(CoreHook::PendingNodeId)
        .and_then(|p| od.entry(p).limits())
        .map(|(lo, hi)| (lo as u8, hi as u8))
        .unwrap_or((128, 247))
}

/// The NAME the dictionary's 3001h holds (all zero fields without one).
pub fn name_of(od: &Od) -> Name {
    // Read in one loop: one lookup in the code rather than ten.
    let mut values = [0u32; 11];
    for (sub, value) in values.iter_mut().enumerate().skip(1) {
        *value = od.value(0x3001, sub as u8).unwrap_or(0);
    }
    let v = |s: u8| values[s as usize];
    let fields = NameFields {
        arbitrary_address_capable: v(10) != 0,
        industry_group: v(9) as u8,
        vehicle_system_instance: v(8) as u8,
        vehicle_system: v(6) as u8,
        reserved: v(7) != 0,
        function: v(5) as u8,
        function_instance: v(4) as u8,
        ecu_instance: v(3) as u8,
        manufacturer_code: v(2) as u16,
        identity_number: v(1),
    };
    Name::from_fields(&fields).unwrap_or(Name::from_raw(0))
}

/// A J1939 node running device `D`.
pub struct J1939Node<D: J1939Device> {
    ctx: Context,
    device: D,
    sdo: SdoServer,
    claim: AddressClaimer,
    cyclic: Scheduler<3>,
    /// Claiming has been started (the first poll after power-on or a restart).
    started: bool,
    /// The requester of the CAM21 write whose answer waits for the store.
    deferred_to: Option<Address>,
    /// The requester of the last CAM21 request (a segmented transfer's timeout goes there).
    requester: Option<Address>,
    bus_off: bool,
    warning: bool,
    passive: bool,
    generation: u32,
    /// The positions of the 3000h cycle time and priority of each cyclic group
    /// ([`PGN_PARAMETERS`]), found once at boot.
    pgn_pos: [(Option<u8>, Option<u8>); 3],
    /// [`J1939Node::next_deadline`] as the last poll left it, while nothing else has touched
    /// the node since (`None`: something has): a poll before it has nothing to do.
    due: Due,
}

impl<D: J1939Device> J1939Node<D> {
    /// A node that has just been powered on with the dictionary as the parameter flash held
    /// it (`storage::ParamFlash::load`): its address and bit rate are the stored 5F0Ah ones
    /// (the defaults on a blank flash). Claiming starts at the first [`J1939Node::poll`].
    pub fn boot(device: D, loaded: &Loaded) -> J1939Node<D> {
        // Built where it lives: the dictionary and the storage are filled in place.
        let od = Od::blank(device.table(), None);
        let mut node = J1939Node {
            ctx: Context::new(od, Storage::empty(loaded), 0, Bitrate::K250),
            device,
            sdo: SdoServer::new(),
            claim: AddressClaimer::new(Name::from_raw(0), Address(0), 0, 0),
            cyclic: Scheduler::new([
                Cyclic::new(Pgn::PROPRIETARY_B, 0, Priority::DEFAULT),
                Cyclic::new(Pgn::ESPD, 0, Priority::DEFAULT),
                Cyclic::new(Pgn::EPOS, 0, Priority::DEFAULT),
            ]),
            started: false,
            deferred_to: None,
            requester: None,
            bus_off: false,
            warning: false,
            passive: false,
            generation: 0,
            due: Due::default(),
            pgn_pos: [(None, None); 3],
        };
        let ctx = &mut node.ctx;
        let address = storage::power_on_in(&mut ctx.od, &mut ctx.storage, loaded, 0xFE);
        ctx.node_id = address;
        ctx.bitrate = pending_bitrate(&node.device, &ctx.od).unwrap_or(Bitrate::K250);
        let (lo, hi) = address_range(&ctx.od);
        let od = &node.ctx.od;
        for (k, &(_, cycle, prio)) in PGN_PARAMETERS.iter().enumerate() {
            let at = |sub| od.pos(0x3000, sub).map(|p| p as u8);
            node.pgn_pos[k] = (at(cycle), at(prio));
        }
        // Error conditions go out as J1939 EMCY, once the claim stood (D-J1939-20).
        node.ctx.errors.announce_with(announce);
        node.ctx.errors.set_gate(Gate::Drop);
        // A parameter flash without a valid image raises 6300h at once (D-STO-8); its EMCY goes
        // out with the conditions still active when the claim has stood.
        node.ctx.boot_up(Instant::ZERO);
        node.device.on_reset(&mut node.ctx, ResetKind::Node, Instant::ZERO);
        node.claim = AddressClaimer::new(name_of(&node.ctx.od), Address(address), lo, hi);
        node.sync_schedule(Instant::ZERO);
        node
    }

    /// The shared state.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The device.
    pub fn device(&self) -> &D {
        &self.device
    }

    /// The address claimer (its state, NAME and delays, for the LEDs and tests).
    pub fn claimer(&self) -> &AddressClaimer {
        &self.claim
    }

    /// The address the node sends from, once its claim has stood.
    pub fn source_address(&self) -> Option<Address> {
        self.claim.source_address()
    }

    /// What the three LEDs show now ([`Leds::lit`] gives the blink phase at an instant).
    pub fn leds(&self) -> Leds {
        led::leds(&LedInputs {
            claim: self.claim.state(),
            bus_off: self.bus_off,
            warning_limit: self.warning || self.passive,
            over_speed: self.device.over_speed(),
        })
    }

    /// The acceptance filters (identifier and mask) for the frames the node acts on now.
    pub fn filters(&self) -> [Filter; 4] {
        rx::filters(self.claim.address())
    }

    /// Handles one received frame.
    #[inline]
    pub fn on_frame(&mut self, frame: &Frame, now: Instant) {
        // A message for another node (PDU1, PF below F0h, with a destination that is neither
        // ours nor global) matters only if it is an address claim (PF EEh) or a request (PF
        // EAh: a Request for Address Claimed to the address being claimed is the claimer's),
        // which the claimer judges: read off the raw identifier, before any parsing.
        if let CanId::Ext(raw) = frame.id {
            let (pf, da) = ((raw >> 16) as u8, (raw >> 8) as u8);
            if pf < 0xF0
                && pf != 0xEE
                && pf != 0xEA
                && da != Address::GLOBAL.0
                && Some(Address(da)) != self.claim.source_address()
            {
                return;
            }
        }
        self.dispatch(frame, now);
    }

    /// A CAM21 message with identifier `raw`: served if it is a request to us
    /// ([`param::cam21_requester`]).
    #[inline(never)]
    fn cam21(&mut self, frame: &Frame, raw: u32, now: Instant) {
        self.due.forget();
        let data = frame.payload();
        let own = self.claim.source_address();
        if let (Some(requester), Some(sa)) = (param::cam21_requester(raw, data.len(), own), own) {
            self.serve(data, requester, sa, now);
        }
    }

    /// A frame the node may act on.
    #[inline(never)]
    fn dispatch(&mut self, frame: &Frame, now: Instant) {
        // A CAM21 request is neither a claim nor a Request: it goes to the parameter access
        // straight off the raw identifier.
        match frame.id {
            CanId::Ext(raw) if param::is_cam21(raw) && !frame.rtr => self.cam21(frame, raw, now),
            _ => self.dispatch_parsed(frame, now),
        }
    }

    /// A frame the node may act on other than a CAM21 request: its identifier parsed.
    #[inline(never)]
    fn dispatch_parsed(&mut self, frame: &Frame, now: Instant) {
        let Ok(id) = Identifier::from_frame(frame) else {
            return;
        };
        self.due.forget();
        let data = frame.payload();
        if id.pgn() == Pgn::ADDRESS_CLAIMED || id.pgn() == Pgn::REQUEST {
            if let Some(f) = self.claim.on_message(&id, data, now) {
                self.ctx.out.send(f);
            }
            self.follow_claim(now);
        }
        let own = self.claim.source_address();
        match request::respond(&id, data, own, &PROVIDED) {
            request::Response::Send { pgn, .. } => {
                if let (Some(sa), Some((_, priority))) = (own, self.cyclic.get(pgn)) {
                    if let Some(f) = self.group_frame(pgn, priority, sa) {
                        self.ctx.out.send(f);
                    }
                }
            }
            request::Response::Nack(f) => self.ctx.out.send(f),
            request::Response::Ignore | request::Response::AddressClaim => {}
        }
        // A CAM21 request never comes here (`dispatch`).
    }

    /// A CAM21 request from `requester` to us at `sa`.
    fn serve(&mut self, data: &[u8], requester: Address, sa: Address, now: Instant) {
        self.requester = Some(requester);
        let J1939Node { ctx, device, sdo, .. } = self;
        // The server is never set to expedited transfers only here.
        let reply = sdo.on_request_as(false, data, now, &mut Access { ctx, device, services: &mut NoServices });
        match reply {
            Some(r) => self.ctx.out.send(param::answer(&r, requester, sa)),
            // A client abort has no answer, and leaves a waiting save's requester alone.
            None if data.first().is_some_and(|c| c >> 5 == 4) => {}
            // A deferred write (1010h "save"): the answer follows the store, to its requester.
            None => self.deferred_to = Some(requester),
        }
        // Only a write can change the cycle times and priorities the scheduler follows (3000h,
        // and 6200h linked to it): an expedited one with its initiate download (001b in the
        // command's top bits), a segmented one with its download segments (000b, the last one writes; D-J1939-28).
        // The device says which 3000h entries the write changed: only their groups are read back.
        if data.first().is_some_and(|cs| cs >> 5 <= 1) {
            let changed = self.device.take_schedule_changes();
            self.sync_slots(changed, now);
        }
        match self.device.take_command() {
            Some(Command::InitialiseSae) => self.restart_claim(now),
            Some(Command::Restart) => self.restart(now),
            None => {}
        }
    }

    /// The CAN controller reported `event`: the LEDs and the device's diagnosis follow.
    pub fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.due.forget();
        match event {
            BusEvent::ErrorPassive => self.passive = true,
            BusEvent::ErrorActive => self.passive = false,
            BusEvent::BusOff => self.bus_off = true,
            BusEvent::BusOffRecovered => {
                self.bus_off = false;
                self.passive = false;
                self.warning = false;
            }
            BusEvent::ErrorCounters { rx, tx } => self.warning = rx >= WARNING_LIMIT || tx >= WARNING_LIMIT,
            BusEvent::RxOverrun | BusEvent::ProtocolError(_) => {}
        }
        self.device.on_bus_event(&mut self.ctx, event, now);
    }

    /// Runs the timers due at `now`.
    #[inline]
    pub fn poll(&mut self, now: Instant) {
        // Nothing has touched the node since the last poll, and its next deadline is later.
        if self.due.nothing_at(now) {
            return;
        }
        self.poll_all(now);
        self.due.remember(self.deadline());
    }

    #[inline(never)]
    fn poll_all(&mut self, now: Instant) {
        if !self.started {
            self.started = true;
            self.claim.start_delayed(now);
        }
        while let Some(f) = self.claim.poll(now) {
            self.ctx.out.send(f);
        }
        self.follow_claim(now);
        if let Some(timeout) = self.sdo.poll(now) {
            if let (Some(rq), Some(sa)) = (self.requester, self.claim.source_address()) {
                self.ctx.out.send(param::answer(&timeout, rq, sa));
            }
        }
        self.device.poll(&mut self.ctx, now);
        while let Some(due) = self.cyclic.poll(now) {
            if let Some(sa) = self.claim.source_address() {
                if let Some(f) = self.group_frame(due.pgn, due.priority, sa) {
                    self.ctx.out.send(f);
                }
            }
        }
    }

    /// When [`J1939Node::poll`] must next run; a poll before it does nothing.
    #[inline]
    pub fn next_deadline(&self) -> Option<Instant> {
        self.due.get(|| self.deadline())
    }

    fn deadline(&self) -> Option<Instant> {
        if !self.started {
            return Some(Instant::ZERO);
        }
        let mut next = self.claim.next_deadline();
        next = earliest(next, self.sdo.next_deadline());
        next = earliest(next, self.cyclic.next_deadline());
        earliest(next, self.device.next_deadline())
    }

    /// Takes the next thing the shell must do.
    pub fn next_output(&mut self) -> Option<Output> {
        self.ctx.out.pop()
    }

    /// The shell has finished (`Ok`) or failed the [`Output::Store`] it was given: the CAM11
    /// answer to the 1010h write goes out now.
    pub fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.due.forget();
        self.ctx.store_done(result.is_ok(), now);
        let reply = self.sdo.complete_deferred(result.map_err(|()| Abort::CANNOT_STORE));
        if let (Some(r), Some(rq), Some(sa)) = (reply, self.deferred_to.take(), self.claim.source_address()) {
            self.ctx.out.send(param::answer(&r, rq, sa));
        }
    }

    /// Starts or stops the cyclic groups as the claim stands or falls; a claim that has just
    /// stood announces the error conditions still active.
    fn follow_claim(&mut self, now: Instant) {
        self.device.on_claim(self.claim.state());
        match (self.claim.source_address(), self.cyclic.is_running()) {
            (Some(sa), false) => {
                // The context's address is the one the node sends from.
                self.ctx.node_id = sa.0;
                self.cyclic.start(now);
                self.generation = self.generation.wrapping_add(1);
                // The conditions still active are announced now, and every change from now on.
                self.ctx.errors.set_gate(Gate::Send);
                self.ctx.errors.defer_active();
                self.ctx.release_deferred();
            }
            (None, true) => {
                self.cyclic.stop();
                self.ctx.errors.set_gate(Gate::Drop);
                self.generation = self.generation.wrapping_add(1);
            }
            _ => {}
        }
    }

    /// The scheduler takes the cycle times and priorities the dictionary holds (3000h).
    fn sync_schedule(&mut self, now: Instant) {
        self.sync_slots(u8::MAX, now);
    }

    /// The scheduler takes the cycle time and priority the dictionary holds for each group
    /// whose 3000h cycle-time or priority sub-index has its bit set in `changed` (bit n:
    /// 3000h.n); the others stay as they are.
    fn sync_slots(&mut self, changed: u8, now: Instant) {
        // Slot k's cycle time is 3000h.(k + 1), its priority 3000h.(k + 4) (PGN_PARAMETERS).
        let mut slots = (changed >> 1 | changed >> 4) & 0b111;
        while slots != 0 {
            let k = slots.trailing_zeros() as usize;
            slots &= slots - 1;
            let Some(&(cycle, prio)) = self.pgn_pos.get(k) else {
                break;
            };
            let od = &self.ctx.od;
            let c = cycle.map_or(0, |pos| od.get(pos as usize)) as u16;
            let p = prio.map_or(6, |pos| od.get(pos as usize)) as u8;
            let p = Priority::new(p).unwrap_or(Priority::DEFAULT);
            self.cyclic.configure(k, c, p, now);
        }
    }

    /// The frame of group `pgn` with the dictionary's current values.
    fn group_frame(&self, pgn: Pgn, priority: Priority, sa: Address) -> Option<Frame> {
        let (position, speed) = self.device.process_data(&self.ctx.od);
        let data = match pgn {
            Pgn::EPOS => Epos { position }.emit(),
            Pgn::ESPD => Espd { speed }.emit(),
            Pgn::PROPRIETARY_B => ProprietaryB { position, speed }.emit(),
            _ => return None,
        };
        Some(Identifier::pdu2(priority, pgn, sa)?.frame(&data))
    }

    /// 3002h.01: claim again at the address 5F0Ah.01 holds now; the table of taken addresses
    /// is forgotten, so a lost address is contested again.
    fn restart_claim(&mut self, now: Instant) {
        let address = storage::pending(&self.ctx.od, CoreHook::PendingNodeId).unwrap_or(0xFE) as u8;
        let (lo, hi) = address_range(&self.ctx.od);
        self.ctx.node_id = address;
        self.claim = AddressClaimer::new(name_of(&self.ctx.od), Address(address), lo, hi);
        self.cyclic.stop();
        self.ctx.errors.set_gate(Gate::Drop);
        self.sdo.reset();
        self.deferred_to = None;
        self.claim.start_delayed(now);
        self.device.on_claim(self.claim.state());
        self.generation = self.generation.wrapping_add(1);
    }

    /// 3002h.02: the device restarts as after power-on: the stored parameters (or the defaults
    /// 1011h marked) are loaded, the stored address and bit rate take effect, claiming starts
    /// again.
    fn restart(&mut self, now: Instant) {
        let device = &self.device;
        self.ctx.reload(ResetKind::Node, |e, groups| device.restores(e, groups));
        if let Some(rate) = pending_bitrate(&self.device, &self.ctx.od) {
            if rate != self.ctx.bitrate {
                self.ctx.bitrate = rate;
                self.ctx.out.push(Output::SetBitrate(rate));
            }
        }
        self.device.on_reset(&mut self.ctx, ResetKind::Node, now);
        self.sync_schedule(now);
        self.restart_claim(now);
    }
}

/// How the context announces an error condition on J1939: the EMCY frame from the node's
/// address (the claimed one: the gate opens only once the claim stood).
fn announce(_: &Od, address: u8, code: u16, register: u8) -> Option<Frame> {
    Some(emcy_frame(code, register, Address(address)))
}

/// The EMCY frame (PGN 64616, priority 1) with `code` and `register` from `sa`.
fn emcy_frame(code: u16, register: u8, sa: Address) -> Frame {
    let priority = Priority::new(EMCY_PRIORITY).unwrap_or(Priority::HIGHEST);
    let data = Emcy { code, register }.emit();
    match Identifier::pdu2(priority, Pgn::EMCY, sa) {
        Some(id) => id.frame(&data),
        None => Frame::new(crate::frame::CanId::Ext(0), &data),
    }
}

impl<D: J1939Device> Station for J1939Node<D> {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        J1939Node::on_frame(self, frame, now)
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        J1939Node::on_bus_event(self, event, now)
    }
    fn poll(&mut self, now: Instant) {
        J1939Node::poll(self, now)
    }
    fn next_deadline(&self) -> Option<Instant> {
        J1939Node::next_deadline(self)
    }
    fn next_output(&mut self) -> Option<Output> {
        J1939Node::next_output(self)
    }
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        J1939Node::store_done(self, result, now)
    }
    /// Empty: a J1939 node receives by identifier and mask ([`Station::rx_masks`]), which
    /// exact identifiers cannot express (claims come from any source address).
    fn rx_ids(&self) -> RxIds {
        RxIds::new()
    }
    /// [`J1939Node::filters`], without repeats.
    fn rx_masks(&self) -> RxMasks {
        let mut masks = RxMasks::new();
        for f in self.filters() {
            if !masks.contains(&(f.id, f.mask)) {
                let _ = masks.push((f.id, f.mask));
            }
        }
        masks
    }
    fn rx_ids_generation(&self) -> u32 {
        self.generation
    }
    fn context(&self) -> &Context {
        &self.ctx
    }
}

impl<D: J1939Device> DeviceStation for J1939Node<D> {
    type Device = D;
    fn device(&self) -> &D {
        &self.device
    }
    fn split(&mut self) -> (&mut D, &mut Context) {
        self.due.forget();
        (&mut self.device, &mut self.ctx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::wv5800m::Turns;
    use crate::devices::wv58mr::Wv58mr;
    use crate::encoder::{Encoder, SensorFault};
    use crate::wire::j1939::{AddressClaimed, CamRequest, Request};

    /// A random input for a WV58MR at `me`: claims of other NAMEs (lower and higher than any
    /// WV58MR's), requests, CAM21 reads and writes (cycle times, save), frames for others.
    fn frame(x: u32, me: Address) -> Frame {
        let other = Address(0x20);
        let v = x >> 8;
        match x % 10 {
            0 => AddressClaimed { name: Name::from_raw(1) }.frame(Address(0xEF)),
            1 => AddressClaimed { name: Name::from_raw(u64::MAX >> 1) }.frame(me),
            2 => Request { pgn: Pgn::ADDRESS_CLAIMED }.frame(Address::GLOBAL, other),
            3 => Request { pgn: Pgn::EPOS }.frame(me, other),
            4 => CamRequest::Read { index: 0x6004, sub: 0 }.frame(me, other),
            5 => CamRequest::Write { index: 0x3000, sub: 2 + (v % 2) as u8, value: v % 200, len: Some(2) }
                .frame(me, other),
            6 => CamRequest::Write { index: 0x1010, sub: 1, value: 0x6576_6173, len: Some(4) }.frame(me, other),
            7 => CamRequest::Read { index: 0x1018, sub: 1 }.frame(Address(me.0 ^ 1), other),
            8 => Request { pgn: Pgn::ESPD }.frame(Address::GLOBAL, other),
            _ => CamRequest::Write { index: 0x6200, sub: 0, value: v % 100, len: Some(2) }.frame(me, other),
        }
    }

    /// Every write of a cycle time or priority (3000h.01..06, and 6200h, which is 3000h.03)
    /// reaches its group in the scheduler, expedited or segmented, and leaves the other groups
    /// as the dictionary holds them: the scheduler reads back only the groups the write named.
    #[test]
    fn each_cycle_and_priority_write_reaches_its_group() {
        let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &Loaded::Blank);
        let mut t = 0;
        while node.source_address().is_none() {
            node.poll(Instant::from_millis(t));
            t += 1;
        }
        let me = node.source_address().unwrap_or(Address(0xEF));
        let client = Address(0x20);
        let expect = |node: &J1939Node<Wv58mr>| {
            PGN_PARAMETERS.map(|(pgn, c, p)| {
                let v = |sub| node.ctx.od.value(0x3000, sub).unwrap_or(0);
                (pgn, Some((v(c) as u16, Priority::new(v(p) as u8).unwrap_or(Priority::DEFAULT))))
            })
        };
        let writes =
            [(0x3000, 1, 120), (0x3000, 2, 70), (0x3000, 3, 90), (0x3000, 4, 2), (0x3000, 5, 1), (0x3000, 6, 7)];
        for (n, &(index, sub, value)) in writes.iter().chain(&[(0x6200, 0, 40)]).enumerate() {
            let now = Instant::from_millis(t + n as u64);
            let (segmented, len) = (n % 2 == 1, if sub >= 4 { 1 } else { 2 });
            if segmented {
                // Initiate with the size, then one last segment with `len` bytes.
                let init = [0x21, index as u8, (index >> 8) as u8, sub, len, 0, 0, 0];
                let last = [(7 - len) << 1 | 1, value as u8, (value >> 8) as u8, 0, 0, 0, 0, 0];
                for d in [init, last] {
                    node.on_frame(&Identifier::pdu1(Priority::DEFAULT, Pgn::CAM21, me, client).unwrap().frame(&d), now);
                }
            } else {
                let f =
                    CamRequest::Write { index, sub, value, len: Some(if sub >= 4 { 1 } else { 2 }) }.frame(me, client);
                node.on_frame(&f, now);
            }
            while node.next_output().is_some() {}
            let value_now = node.ctx.od.value(index, sub);
            assert_eq!(value_now, Some(value), "{index:04X}h.{sub:02X} not written");
            let got = PGN_PARAMETERS.map(|(pgn, ..)| (pgn, node.cyclic.get(pgn)));
            assert_eq!(got, expect(&node), "after {index:04X}h.{sub:02X} := {value}");
        }
        assert_eq!(node.ctx.od.value(0x3000, 3), Some(40), "6200h is 3000h.03");
    }

    /// A poll before the remembered deadline does exactly what a full poll does: two nodes get
    /// the same random frames, bus events, samples and polls; one forgets its deadline before
    /// every poll; their outputs and deadlines never differ.
    #[test]
    fn a_poll_before_the_deadline_is_a_full_poll() {
        for seed in 0..6u32 {
            let make = || J1939Node::boot(Wv58mr::new(Turns::Multi12), &Loaded::Blank);
            let (mut a, mut b) = (make(), make());
            let (mut x, mut t, mut skipped) = (seed, 0u64, 0);
            for step in 0..6000 {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                let now = Instant::from_micros(t);
                let me = a.source_address().unwrap_or(Address(0xEF));
                match (x >> 28) % 8 {
                    0..=2 => {
                        let f = frame(x >> 4, me);
                        a.on_frame(&f, now);
                        b.on_frame(&f, now);
                    }
                    3 => {
                        let raw =
                            if (x >> 8) % 5 == 0 { Err(SensorFault::Diagnosis) } else { Ok((x >> 8) % (1 << 24)) };
                        let (d, c) = DeviceStation::split(&mut a);
                        d.on_sample(c, raw, now);
                        let (d, c) = DeviceStation::split(&mut b);
                        d.on_sample(c, raw, now);
                    }
                    4 => {
                        let e = [
                            BusEvent::ErrorPassive,
                            BusEvent::ErrorActive,
                            BusEvent::BusOff,
                            BusEvent::BusOffRecovered,
                        ][(x >> 8) as usize % 4];
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
                    assert_eq!(oa, ob, "seed {seed} step {step} at {t} µs");
                    match oa {
                        Some(Output::Store(_)) => {
                            a.store_done(Ok(()), now);
                            b.store_done(Ok(()), now);
                        }
                        Some(_) => {}
                        None => break,
                    }
                }
                assert_eq!(a.next_deadline(), b.deadline(), "seed {seed} step {step} at {t} µs");
                t += [0, 1, 100, 999, 1000, 7_000, 60_000][(x >> 12) as usize % 7];
            }
            assert!(skipped > 100, "{skipped} polls skipped");
        }
    }
}
