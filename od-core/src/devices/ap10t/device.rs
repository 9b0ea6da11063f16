//! The AP10T as a CANopen device: the [`Panel`] wired to its dictionary.
//!
//! - RPDO1/RPDO2 write set point 1/2 (5F16h) and the control word (5F0Ch) into the dictionary
//!   (OPERATIONAL only, the PDO service's rule); [`CanopenDevice::on_rpdo`] hands the eight bytes to
//!   the panel and refreshes the dictionary's views of it: the status word 5F19h and the set
//!   points the TPDOs carry (5F1Dh).
//! - TPDO1 (event timer = 6200h) and TPDO2 (SYNC) are the PDO service's, from 5F1Dh and 5F19h.
//!   A remote frame on an RPDO identifier is answered with the TPDO of the same set point on
//!   that identifier, status word bit 9 = its data identifier (D-PDO-7, D-AP-13).
//! - Keys come from the shell ([`Ap10t::press`], [`Ap10t::release`]); the status word follows
//!   the keys held, and the menu's effects change 5F0Ah (kept at once, D-AP-16) or restore the
//!   factory settings (D-AP-17).
//! - 5F0Ah.02 starts the Auto-ID on a node whose node-ID is 7Dh (D-AP-18); 5F09h is the
//!   external heartbeat (D-AP-19); 1011h sub 2 restores the "bus parameters" of Table 4
//!   ([`Device::restores`], D-AP-15); no LSS.
//!
//! The panel is pure ([`super::panel`]); this module only moves values between it and the
//! dictionary, so the trait impl stays thin.

use crate::abort::Abort;
use crate::bitrate::Bitrate;
use crate::context::Written;
use crate::encoder::linear::{CanDiagnosis, EMCY_BUS_OFF, EMCY_PASSIVE};
use crate::encoder::EmcyConditions;
use crate::nmt::NmtState;
use crate::node::{BusEvent, CanopenDevice, Core, Device, DeviceRequests, Link, ResetKind};
use crate::od::{CoreHook, Entry, Group, GroupMask, Hook};
use crate::pdo::{RtrAnswer, RtrReply};
use crate::time::Instant;

use super::keys::Key;
use super::menu::{DiagEntry, Effect, ResetScope};
use super::panel::{Panel, Params, View};
use super::setpoint::Which;
use super::table::{at, hooks, BITRATE_CODES, DEFAULT_NODE_ID, TABLE};
use super::words::sw;

/// The "bus parameters" of manual Table 4, as (index, sub): what 1011h sub 2 and CODE 011105
/// restore, and what CODE 011102 keeps. 1001h (not stored) is cleared by any reset anyway.
pub const BUS_PARAMETERS: [(u16, u8); 18] = [
    (0x5F0A, 1),
    (0x5F0A, 3),
    (0x1005, 0),
    (0x100C, 0),
    (0x100D, 0),
    (0x1014, 0),
    (0x1017, 0),
    (0x1400, 1),
    (0x1400, 2),
    (0x1401, 1),
    (0x1401, 2),
    (0x1800, 1),
    (0x1800, 2),
    (0x1800, 5),
    (0x1801, 1),
    (0x1801, 2),
    (0x5F09, 1),
    (0x5F09, 2),
];

/// Is `e` a bus parameter (Table 4)? 6200h is the same value as 1800h.05 and goes with it.
pub fn is_bus_parameter(e: &Entry) -> bool {
    (e.index, e.sub) == (0x6200, 0) || BUS_PARAMETERS.iter().any(|&(i, s)| i == e.index && s == e.sub)
}

/// The rates the automatic detection tries, in this order (5F0Ah.03 codes 1..5).
pub static AUTO_BITRATES: [Bitrate; 5] = [Bitrate::K125, Bitrate::K250, Bitrate::K500, Bitrate::K800, Bitrate::K1000];

// Condition numbers in `EmcyConditions`.
const C_PASSIVE: usize = 0;
const C_BUS_OFF: usize = 1;

/// An AP10T.
#[derive(Clone, Debug)]
pub struct Ap10t {
    panel: Panel,
    started: bool,
    /// The node is OPERATIONAL (as the last NMT change said).
    operational: bool,
    /// The external heartbeat's deadline (5F09h), while it runs.
    heartbeat_due: Option<Instant>,
    /// A menu factory reset under way: what the next reset restores.
    menu_reset: Option<ResetScope>,
    /// Store every group after the next reset (a menu factory reset is kept, D-AP-17).
    store_after_reset: bool,
    /// What the node must do next ([`Ap10t::requests`]).
    requests: DeviceRequests,
    conditions: EmcyConditions,
    passive: bool,
    recovered: bool,
    can: CanDiagnosis,
}

impl Default for Ap10t {
    fn default() -> Self {
        Ap10t::new()
    }
}

impl Ap10t {
    /// A display before power-on.
    pub fn new() -> Ap10t {
        Ap10t {
            panel: Panel::new(Params::FACTORY),
            started: false,
            operational: false,
            heartbeat_due: None,
            menu_reset: None,
            store_after_reset: false,
            requests: DeviceRequests::default(),
            conditions: EmcyConditions::new(),
            passive: false,
            recovered: false,
            can: CanDiagnosis::default(),
        }
    }

    /// The front panel.
    pub fn panel(&self) -> &Panel {
        &self.panel
    }

    /// What the operator sees at `now`.
    pub fn view(&self, now: Instant) -> View {
        self.panel.view(now)
    }

    /// When the view next changes by itself after `now` (blinking, a time-out).
    pub fn next_change(&self, now: Instant) -> Option<Instant> {
        self.panel.next_change(now)
    }

    /// The diagnosis list (CODE 200000) from the error history 1003h, into the panel: each
    /// error code once, the latest first, with how often the history holds it (D-AP-23).
    fn load_diagnosis(&mut self, core: &Core) {
        let list = self.panel.diagnosis_mut();
        list.clear();
        let n = core.od.get(at::ERROR_HISTORY).min(8) as usize;
        for sub in 1..=n {
            let code = core.od.get(at::ERROR_HISTORY + sub) as u16;
            match list.iter_mut().find(|e| e.code == code) {
                Some(e) => e.count = e.count.saturating_add(1),
                None => {
                    let _ = list.push(DiagEntry { code, count: 1 });
                }
            }
        }
    }

    /// The panel parameters made what the dictionary holds, in place.
    fn load_params(&mut self, core: &Core) {
        let p = &mut self.panel.params;
        *p = Params::FACTORY;
        for (i, &pos) in at::PANEL.iter().enumerate() {
            let _ = p.write_nth(i, core.od.get(pos as usize));
        }
    }

    fn ensure_started(&mut self, core: &mut Core, now: Instant) {
        if !self.started {
            self.started = true;
            self.panel.power_up(now);
            self.start(core);
        }
    }

    /// Brings the device in line with the dictionary after power-on or a reset.
    fn start(&mut self, core: &mut Core) {
        let od = &mut core.od;
        // 6200h and 1800h.05 are one value in two objects of two storage groups: after a
        // reset, the one that differs from its default wins, 1800h.05 when both do.
        let (va, vb) = (od.get(at::EVENT_TIMER), od.get(at::CYCLE_TIMER));
        let v = if va != 0 || vb == 0 { va } else { vb };
        od.set(at::EVENT_TIMER, v);
        od.set(at::CYCLE_TIMER, v);
        self.load_params(core);
        self.can = CanDiagnosis::default();
        core.od.set(at::CAN_DIAGNOSIS, 0);
        self.operational = false;
        self.heartbeat_due = None;
        self.refresh(core);
    }

    /// Writes the panel's state into its dictionary views: 5F19h (bit 9 = 0) and the set
    /// points the TPDOs carry (5F1Dh).
    fn refresh(&self, core: &mut Core) {
        let od = &mut core.od;
        od.set(at::STATUS_WORD, self.panel.status_bits() as u32);
        // 5F1Dh sub 1..=4: set point 2's four and two bytes, then set point 1's.
        for (i, sp) in self.panel.set_points().sp.iter().rev().enumerate() {
            let b = sp.bytes;
            od.set(at::TPDO_SET_POINTS + 2 * i, u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            od.set(at::TPDO_SET_POINTS + 2 * i + 1, u16::from_le_bytes([b[4], b[5]]) as u32);
        }
    }

    /// The eight bytes RPDO `which` delivered, read back from the mapped entries.
    fn rpdo_data(core: &Core, which: Which) -> [u8; 8] {
        // 5F16h sub 1..=4: set point 2's four and two bytes, then set point 1's.
        let lsb = match which {
            Which::Sp1 => at::RPDO_SET_POINTS + 2,
            Which::Sp2 => at::RPDO_SET_POINTS,
        };
        let v = |pos| core.od.get(pos) as u64;
        (v(lsb) | (v(lsb + 1) & 0xFFFF) << 32 | (v(at::CONTROL_WORD) & 0xFFFF) << 48).to_le_bytes()
    }

    /// A key was pressed (its debounced edge) at `now`.
    pub fn press(&mut self, core: &mut Core, key: Key, now: Instant) {
        self.ensure_started(core, now);
        self.load_params(core);
        self.load_diagnosis(core);
        let effect = self.panel.press(key, now);
        self.refresh(core);
        match effect {
            None | Some(Effect::Acknowledged) => {}
            Some(Effect::SetNodeId(id)) => self.keep(core, 1, id, GroupMask::NODE_ID),
            Some(Effect::SetBaud(code)) => self.keep(core, 3, code, GroupMask::BITRATE),
            Some(Effect::FactoryReset(scope)) => {
                self.menu_reset = Some(scope);
                core.storage.mark_restore(GroupMask::ALL);
                self.store_after_reset = true;
                self.requests.reset = Some(ResetKind::Node);
            }
            Some(Effect::AutoIdAdopted(id)) => {
                // Manual 4.6.2: the SDO reply (on the old identifier), the node-ID stored,
                // the initialisation again, the boot-up with the new node-ID.
                core.od.set(at::NODE_ID, id as u32);
                let _ = core.request_store(GroupMask::NODE_ID);
                self.requests.sdo = Some(Ok(()));
                self.requests.reset = Some(ResetKind::Communication);
            }
        }
        // The menu shows what the dictionary now holds.
        self.load_params(core);
    }

    /// A key was released.
    pub fn release(&mut self, core: &mut Core, key: Key, now: Instant) {
        self.ensure_started(core, now);
        self.panel.release(key);
        self.refresh(core);
    }

    /// A menu change of 5F0Ah sub `sub`: into the dictionary and kept at once (that entry
    /// alone, `mask`); adopted at the next initialisation (D-AP-16).
    fn keep(&mut self, core: &mut Core, sub: u8, value: u8, mask: GroupMask) {
        core.od.set(at::NODE_ID + sub as usize - 1, value as u32);
        let _ = core.request_store(mask);
    }

    /// (Re)arms the external heartbeat (5F09h) at `now`: it runs in OPERATIONAL when 5F09h.01
    /// is not 0.
    fn arm_heartbeat(&mut self, core: &Core, now: Instant) {
        // 5F09h.01 is UNSIGNED16: its microseconds fit 32 bits.
        let ms = core.od.get(at::EXTERNAL_HEARTBEAT_TIME) & 0xFFFF;
        self.heartbeat_due = (self.operational && ms != 0).then(|| now.add_micros((ms * 1000) as u64));
    }

    /// A trigger of the external heartbeat arrived: an RPDO (`sync` false) or a SYNC.
    fn heartbeat_trigger(&mut self, core: &Core, sync: bool, now: Instant) {
        let source_sync = core.od.get(at::EXTERNAL_HEARTBEAT_SOURCE) == 1;
        if source_sync == sync {
            self.arm_heartbeat(core, now);
        }
    }

    /// Before the answer to a remote request for set point `n` + 1: only that answer carries
    /// the data identifier in status word bit 9 (D-AP-13), so 5F19h gets it for the answer;
    /// returns the plain status word, which the caller puts back after sending.
    #[inline(never)]
    fn remote_status(&self, core: &mut Core, n: u8) -> u32 {
        let which = if n == 0 { Which::Sp1 } else { Which::Sp2 };
        let plain = self.panel.status_bits();
        let ascii = self.panel.set_points().get(which).ascii;
        core.od.set(at::STATUS_WORD, (plain | if ascii { sw::ASCII } else { 0 }) as u32);
        plain as u32
    }

    fn report(&mut self, core: &mut Core, now: Instant) {
        let c = &mut self.conditions;
        c.update(core, C_PASSIVE, EMCY_PASSIVE, self.passive, now);
        if self.recovered {
            self.recovered = false;
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, true, now);
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, false, now);
        }
    }
}

impl Device for Ap10t {
    fn table(&self) -> &'static [Entry] {
        TABLE
    }

    fn bitrate_codes(&self) -> &'static [(u32, Bitrate)] {
        BITRATE_CODES
    }

    /// 6200h and 1800h.05 are one value: a write to either follows TPDO1's event-timer rule.
    fn link(&self, e: &Entry) -> Option<Link> {
        (e.hook == Hook::Device(hooks::CYCLE_TIMER)).then_some(Link {
            index: 0x1800,
            sub: 5,
            hook: CoreHook::PdoEventTimer,
        })
    }

    /// 1011h sub 2 restores the bus parameters of Table 4 (5F0Ah.01/.03, 5F09h among them) and
    /// not the rest of 1000h-1FFFh; sub 3 the application parameters and sub 4 the
    /// manufacturer ones by their index ranges; 1800h.05 and 6200h go together (D-AP-15). A
    /// menu CODE restores its scope (Table 3).
    fn restores(&self, e: &Entry, groups: GroupMask) -> bool {
        let bus = is_bus_parameter(e);
        let timer = matches!((e.index, e.sub), (0x1800, 5) | (0x6200, 0));
        match self.menu_reset {
            Some(ResetScope::All) => return true,
            Some(ResetScope::AllExceptBus) => return !bus,
            Some(ResetScope::BusOnly) => return bus,
            None => {}
        }
        if groups == GroupMask::ALL {
            return true;
        }
        (groups.contains(Group::Comm) && bus)
            || (groups.contains(Group::App) && (e.group == Group::App || timer))
            || (groups.contains(Group::Manuf) && e.group == Group::Manuf)
    }

    fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        self.on_write_deferred(core, pos, value, now).map(|_| ())
    }

    fn on_write_deferred(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<Written, Abort> {
        self.ensure_started(core, now);
        let e = core.od.entry(pos);
        let Hook::Device(hook) = e.hook else { return Ok(Written::Done) };
        match hook {
            // The access path has applied the event-timer rule (`link`).
            hooks::CYCLE_TIMER => {
                core.od.set(at::EVENT_TIMER, value);
                core.od.set(at::CYCLE_TIMER, value);
            }
            // The hook numbers the parameter (`hooks::PANEL`); a refused value leaves the
            // parameters as they were.
            h if h >= hooks::PANEL => {
                self.panel.params.write_nth((h - hooks::PANEL) as usize, value).map_err(|_| Abort::INVALID_VALUE)?;
            }
            hooks::EXTERNAL_HEARTBEAT => {
                if e.sub == 1 && (1..10).contains(&value) {
                    return Err(Abort::INVALID_VALUE);
                }
                core.od.set(pos, value);
                self.arm_heartbeat(core, now);
            }
            // Only a display that still has the factory node-ID takes part (manual 4.6.2: "all
            // devices that have the current Node-ID 7Dh"); the answer waits for the key.
            // Elsewhere the value is only stored. Not while a store is under way (a 1010h save
            // whose answer a reset dropped): its result would answer this write before any key,
            // and the key could not store the ID; refused as a second save is (D-AP-25).
            hooks::AUTO_ID if core.node_id == DEFAULT_NODE_ID => {
                if core.storage.saving() {
                    return Err(Abort::DEVICE_STATE);
                }
                if !self.panel.start_auto_id(value as u8) {
                    return Err(Abort::INVALID_VALUE);
                }
                return Ok(Written::Deferred);
            }
            _ => {}
        }
        Ok(Written::Done)
    }

    fn take_requests(&mut self) -> DeviceRequests {
        core::mem::take(&mut self.requests)
    }

    fn has_requests(&self) -> bool {
        self.requests != DeviceRequests::default()
    }

    fn on_reset(&mut self, core: &mut Core, kind: ResetKind, now: Instant) {
        let _ = kind;
        self.ensure_started(core, now);
        self.menu_reset = None;
        self.panel.end_auto_id();
        self.start(core);
        if core::mem::take(&mut self.store_after_reset) {
            let _ = core.request_store(GroupMask::ALL);
        }
        self.report(core, now);
    }

    fn poll(&mut self, core: &mut Core, now: Instant) {
        self.ensure_started(core, now);
        if self.heartbeat_due.is_some_and(|t| t <= now) {
            // Ran out: the node goes to PRE-OPERATIONAL (D-AP-19).
            self.heartbeat_due = None;
            self.requests.pre_operational = true;
        }
        self.report(core, now);
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.heartbeat_due
    }

    fn on_bus_event(&mut self, core: &mut Core, event: BusEvent, now: Instant) {
        self.ensure_started(core, now);
        match event {
            BusEvent::ErrorPassive => self.passive = true,
            BusEvent::ErrorActive => self.passive = false,
            BusEvent::BusOff => {}
            BusEvent::BusOffRecovered => {
                self.passive = false;
                self.recovered = true;
            }
            BusEvent::RxOverrun => {}
            BusEvent::ProtocolError(e) => {
                self.can.count(e);
                core.od.set(at::CAN_DIAGNOSIS, self.can.ranking());
            }
            BusEvent::ErrorCounters { rx, tx } => {
                core.od.set(at::STATUS_REGISTER, rx as u32 | (tx as u32) << 8);
            }
        }
        self.report(core, now);
    }
}

impl CanopenDevice for Ap10t {
    fn has_lss(&self) -> bool {
        false
    }

    /// The rates of 5F0Ah.03, slowest first (AP10T A31, D-AP-20).
    fn auto_bitrates(&self) -> &'static [Bitrate] {
        &AUTO_BITRATES
    }

    fn sdo_expedited_only(&self) -> bool {
        true
    }

    fn on_rpdo(&mut self, core: &mut Core, n: u8, now: Instant) {
        self.ensure_started(core, now);
        let which = if n == 0 { Which::Sp1 } else { Which::Sp2 };
        self.panel.receive(which, &Ap10t::rpdo_data(core, which));
        self.refresh(core);
        self.heartbeat_trigger(core, false, now);
    }

    fn on_rpdo_rtr(&mut self, core: &mut Core, n: u8, reply: &RtrReply, now: Instant) {
        self.ensure_started(core, now);
        let plain = self.remote_status(core, n);
        reply.send(core, n);
        core.od.set(at::STATUS_WORD, plain);
    }

    fn on_tpdo_rtr(&mut self, core: &mut Core, n: u8, answer: &RtrAnswer, now: Instant) {
        self.ensure_started(core, now);
        let plain = self.remote_status(core, n);
        answer.send(core);
        core.od.set(at::STATUS_WORD, plain);
    }

    fn on_sync(&mut self, core: &mut Core, now: Instant) {
        self.ensure_started(core, now);
        self.heartbeat_trigger(core, true, now);
    }

    fn on_nmt(&mut self, core: &mut Core, nmt: NmtState, now: Instant) {
        self.ensure_started(core, now);
        // The external heartbeat starts on entering OPERATIONAL and stops on leaving it.
        let was = self.operational;
        self.operational = nmt == NmtState::Operational;
        if !self.operational {
            self.heartbeat_due = None;
        } else if !was {
            self.arm_heartbeat(core, now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn restored(d: &Ap10t, groups: GroupMask) -> impl Iterator<Item = (u16, u8)> + '_ {
        TABLE.iter().filter(move |e| e.group != Group::None && d.restores(e, groups)).map(|e| (e.index, e.sub))
    }

    #[test]
    fn restore_scopes_of_1011h_and_the_menu_codes() {
        let mut d = Ap10t::new();
        let comm = GroupMask::from_subindex(2).unwrap();
        let app = GroupMask::from_subindex(3).unwrap();
        let manuf = GroupMask::from_subindex(4).unwrap();
        // Sub 2: exactly Table 4 (and 6200h, the same value as 1800h.05).
        let mut bus: heapless::Vec<(u16, u8), 24> = restored(&d, comm).collect();
        bus.sort();
        let mut want: heapless::Vec<(u16, u8), 24> = BUS_PARAMETERS.iter().copied().collect();
        want.push((0x6200, 0)).unwrap();
        want.sort();
        assert_eq!(bus, want);
        // Sub 3: 6200h and 1800h.05; sub 4: the manufacturer range, 5F0Ah and 5F09h included.
        assert!(restored(&d, app).eq([(0x1800, 5), (0x6200, 0)]));
        assert!(restored(&d, manuf).all(|(i, _)| (0x2000..=0x5FFF).contains(&i)));
        assert!(restored(&d, manuf).any(|x| x == (0x5F0A, 2)) && restored(&d, manuf).any(|x| x == (0x5F09, 1)));
        assert_eq!(restored(&d, GroupMask::ALL).count(), TABLE.iter().filter(|e| e.group != Group::None).count());
        // The menu CODEs.
        d.menu_reset = Some(ResetScope::BusOnly);
        assert!(restored(&d, GroupMask::ALL).eq(restored(&Ap10t::new(), comm)));
        d.menu_reset = Some(ResetScope::AllExceptBus);
        assert!(restored(&d, GroupMask::ALL).all(|(i, s)| !BUS_PARAMETERS.contains(&(i, s)) && (i, s) != (0x6200, 0)));
        assert!(restored(&d, GroupMask::ALL).any(|x| x == (0x1003, 0)));
    }
}
