//! EMCY producer (CiA 301 §7.2.7), the 1001h error register and the 1003h error history.
//!
//! A device reports error conditions with [`set_error`]; this module owns what follows on the
//! bus and in the dictionary. The rules (decisions D-EMCY-n in `docs/decisions.md`):
//! - a rising condition sends one EMCY `code`, sets its bits in 1001h (bit 0 whenever any error
//!   is active) and enters `code` at 1003h.01, older entries moving one sub-index up;
//! - a falling condition sends the "error reset" EMCY 0000h with 1001h recomputed from the
//!   conditions still active; it is not entered in the history;
//! - the frame is 8 bytes: code LSB first, 1001h, five manufacturer bytes 00h;
//! - EMCY frames go out in PRE-OPERATIONAL and OPERATIONAL only, and only while 1014h bit 31 is
//!   0; one that falls due in STOPPED or with an invalid COB-ID is dropped (1001h and 1003h
//!   still record it); one that falls due before the boot-up message is sent right after it;
//! - after an NMT reset every condition still active is announced again after the boot-up;
//! - no inhibit time: none of the manuals has 1015h.

use crate::abort::Abort;
use crate::frame::{CanId, Frame};
use crate::nmt::NmtState;
use crate::node::Core;
use crate::od::CoreHook;
use crate::time::Instant;
use crate::wire::emcy::EmcyMessage;

/// Index of the error register.
pub const ERROR_REGISTER: u16 = 0x1001;
/// Index of the pre-defined error field (error history).
pub const ERROR_HISTORY: u16 = 0x1003;
/// Index of the EMCY COB-ID.
pub const COB_ID_EMCY: u16 = 0x1014;
pub use crate::wire::emcy::NO_ERROR;
/// 1001h bit 0: generic error, set while any error condition is active.
pub const GENERIC: u8 = 0x01;
/// 1001h bit 4: communication error (error passive, bus-off).
pub const COMMUNICATION: u8 = 0x10;
/// 1001h bit 7: manufacturer-specific (the SIKO sensor errors).
pub const MANUFACTURER: u8 = 0x80;

/// Most error conditions active at once that the producer tracks. The manuals list at most
/// seven codes per device.
pub const MAX_ACTIVE: usize = 16;
/// Most EMCY frames waiting for the boot-up message.
pub const MAX_DEFERRED: usize = 8;

const VALID_BIT: u32 = 1 << 31;
const RESERVED_BIT: u32 = 1 << 30;
const EXTENDED_BIT: u32 = 1 << 29;

/// One active error condition: its code and the 1001h bits it sets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Active {
    code: u16,
    bits: u8,
}

/// EMCY producer state.
#[derive(Clone, Default)]
pub struct Emcy {
    /// The conditions active now.
    active: heapless::Vec<Active, MAX_ACTIVE>,
    /// (code, error register) of frames that fell due before the boot-up message.
    deferred: heapless::Deque<(u16, u8), MAX_DEFERRED>,
}

impl Emcy {
    /// Is the condition `code` active?
    pub fn is_active(&self, code: u16) -> bool {
        self.active.iter().any(|a| a.code == code)
    }

    /// The error register as the active conditions make it.
    pub fn register(&self) -> u8 {
        let mut reg = 0;
        for a in &self.active {
            reg |= a.bits | GENERIC;
        }
        reg
    }
}

/// Sets or clears the error condition `code` (for example FF15h, 8120h).
///
/// On a rising condition the node sends one EMCY with `code`, sets `register_bits` in 1001h
/// (bit 0 is implied) and enters the code in the 1003h history. On a falling condition it sends
/// the "error reset" EMCY 0000h and recomputes 1001h from the errors still active. Calling it
/// again with the same state does nothing ("only once per error event"). Code 0000h is not an
/// error condition and is ignored.
pub fn set_error(core: &mut Core, code: u16, register_bits: u8, active: bool, now: Instant) {
    let _ = now;
    if code == NO_ERROR {
        return;
    }
    let at = core.emcy.active.iter().position(|a| a.code == code);
    let sent = match (active, at) {
        (true, None) => {
            // Full: the condition still reaches the bus, 1001h and 1003h; only its falling edge
            // cannot be matched. Seven codes per device make this unreachable in practice.
            let _ = core.emcy.active.push(Active { code, bits: register_bits });
            history_push(core, code);
            code
        }
        (false, Some(i)) => {
            core.emcy.active.swap_remove(i);
            NO_ERROR
        }
        _ => return,
    };
    let mut register = core.emcy.register();
    if active && at.is_none() {
        register |= register_bits | GENERIC;
    }
    core.od.set_value(ERROR_REGISTER, 0, register as u32);
    emit(core, sent, register);
}

/// Puts an EMCY on the bus, defers it to after the boot-up message, or drops it, as the NMT
/// state and 1014h allow.
fn emit(core: &mut Core, code: u16, register: u8) {
    match core.nmt {
        NmtState::Initialising => {
            let _ = core.emcy.deferred.push_back((code, register));
        }
        state if state.emcy_allowed() => {
            if let Some(id) = cob_id(core) {
                core.out.send(Frame::new(id, &EmcyMessage::new(code, register).emit()));
            }
        }
        _ => {}
    }
}

/// The identifier 1014h designates, `None` while its valid bit says "does not exist".
fn cob_id(core: &Core) -> Option<CanId> {
    let raw = core.od.value(COB_ID_EMCY, 0).unwrap_or(0x80 + core.node_id as u32);
    if raw & VALID_BIT != 0 {
        None
    } else {
        Some(CanId::from_cob_id(raw))
    }
}

/// Enters `code` at 1003h.01; older entries move up one sub-index, the oldest falls out when
/// the history is full; sub 0 counts the entries.
fn history_push(core: &mut Core, code: u16) {
    let Some(head) = core.od.pos(ERROR_HISTORY, 0) else {
        return;
    };
    let table = core.od.table();
    let capacity = table[head + 1..].iter().take_while(|e| e.index == ERROR_HISTORY).count();
    if capacity == 0 {
        return;
    }
    for k in (1..capacity).rev() {
        let older = core.od.get(head + k);
        core.od.set(head + k + 1, older);
    }
    core.od.set(head + 1, code as u32);
    let count = (core.od.get(head) as usize + 1).min(capacity);
    core.od.set(head, count as u32);
}

/// Clears the producer's state after a reset communication: frames not yet sent are dropped,
/// and every condition still active is announced again after the boot-up message (the
/// condition persists; the master learns of it in the new session). 1001h keeps its value;
/// the 1003h history is a log and stays.
pub fn reset(core: &mut Core) {
    core.emcy.deferred.clear();
    let register = core.emcy.register();
    let Core { emcy, .. } = core;
    for a in emcy.active.iter() {
        let _ = emcy.deferred.push_back((a.code, register));
    }
}

/// Runs due work: sends the EMCY frames deferred until the boot-up message.
pub fn poll(core: &mut Core, now: Instant) {
    let _ = now;
    if core.emcy.deferred.is_empty() || core.nmt == NmtState::Initialising {
        return;
    }
    while let Some((code, register)) = core.emcy.deferred.pop_front() {
        emit(core, code, register);
    }
}

/// Checks a write to 1003h sub 0 (only 0, which clears the history) or 1014h; on `Ok` the
/// node stores the value.
///
/// 1014h (CiA 301 §7.5.2.7 and the manuals' 1014h description): writable in PRE-OPERATIONAL
/// only (08000022h otherwise); bit 30 is always 0; an 11-bit identifier leaves bits 28..11 at
/// 0; the identifier may change only while the COB-ID is invalid (bit 31 = 1), in the written
/// or the stored value; a restricted identifier (CiA 301 table 70) is refused. Every refusal
/// of a value is 06090030h.
pub fn on_write(core: &mut Core, hook: CoreHook, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
    let _ = now;
    match hook {
        CoreHook::ErrorHistory => {
            if value != 0 {
                return Err(Abort::INVALID_VALUE);
            }
            let table = core.od.table();
            let members = table[pos + 1..].iter().take_while(|e| e.index == table[pos].index).count();
            for k in 1..=members {
                core.od.set(pos + k, 0);
            }
            Ok(())
        }
        CoreHook::EmcyCobId => {
            if core.nmt != NmtState::PreOperational {
                return Err(Abort::DEVICE_STATE);
            }
            check_cob_id(core.od.get(pos), value)
        }
        _ => Ok(()),
    }
}

/// The 1014h value rules, without the NMT state.
fn check_cob_id(old: u32, new: u32) -> Result<(), Abort> {
    if new & RESERVED_BIT != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    if new & EXTENDED_BIT == 0 && new & 0x1FFF_F800 != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    let id = CanId::from_cob_id(new);
    if id.is_restricted() {
        return Err(Abort::INVALID_VALUE);
    }
    let both_valid = old & VALID_BIT == 0 && new & VALID_BIT == 0;
    if both_valid && CanId::from_cob_id(old) != id {
        return Err(Abort::INVALID_VALUE);
    }
    Ok(())
}

/// Refuses reads the dictionary alone cannot judge: a 1003h entry above the error count
/// (08000024h "no data available", CiA 301 §7.5.2.4).
pub fn check_read(core: &Core, index: u16, sub: u8) -> Result<(), Abort> {
    if index != ERROR_HISTORY || sub == 0 {
        return Ok(());
    }
    match core.od.value(ERROR_HISTORY, 0) {
        Some(count) if sub as u32 > count => Err(Abort::NO_DATA),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::Bitrate;
    use crate::devices::sgh10;
    use crate::node::{Device, Node, Output};

    struct T;
    impl Device for T {
        fn table(&self) -> &'static [crate::od::Entry] {
            sgh10::TABLE
        }
    }

    fn booted() -> Node<T> {
        let mut node = Node::new(T, 1, Bitrate::K500);
        node.poll(Instant::ZERO);
        assert_eq!(node.next_output(), Some(Output::Frame(Frame::std(0x701, &[0]))));
        node
    }

    fn frames(node: &mut Node<T>) -> heapless::Vec<Frame, 16> {
        let mut v = heapless::Vec::new();
        while let Some(o) = node.next_output() {
            if let Output::Frame(f) = o {
                v.push(f).unwrap();
            }
        }
        v
    }

    #[test]
    fn rising_and_falling_conditions() {
        let mut node = booted();
        let now = Instant::ZERO;
        set_error(node.split().1, 0xFF15, MANUFACTURER, true, now);
        set_error(node.split().1, 0xFF15, MANUFACTURER, true, now);
        assert_eq!(frames(&mut node).as_slice(), &[Frame::std(0x81, &[0x15, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
        set_error(node.split().1, 0x8120, COMMUNICATION, true, now);
        assert_eq!(frames(&mut node).as_slice(), &[Frame::std(0x81, &[0x20, 0x81, 0x91, 0, 0, 0, 0, 0])]);
        set_error(node.split().1, 0xFF15, MANUFACTURER, false, now);
        set_error(node.split().1, 0xFF15, MANUFACTURER, false, now);
        assert_eq!(frames(&mut node).as_slice(), &[Frame::std(0x81, &[0, 0, 0x11, 0, 0, 0, 0, 0])]);
        set_error(node.split().1, 0x8120, COMMUNICATION, false, now);
        assert_eq!(frames(&mut node).as_slice(), &[Frame::std(0x81, &[0, 0, 0, 0, 0, 0, 0, 0])]);
        let od = &node.core().od;
        assert_eq!(od.value(0x1001, 0), Some(0));
        assert_eq!(
            (od.value(0x1003, 0), od.value(0x1003, 1), od.value(0x1003, 2)),
            (Some(2), Some(0x8120), Some(0xFF15))
        );
        set_error(node.split().1, 0, MANUFACTURER, true, now);
        assert!(frames(&mut node).is_empty());
    }

    #[test]
    fn history_keeps_the_newest_eight() {
        let mut node = booted();
        for code in 1..=10u16 {
            set_error(node.split().1, 0xFF00 + code, 0, true, Instant::ZERO);
        }
        let od = &node.core().od;
        assert_eq!(od.value(0x1003, 0), Some(8));
        for sub in 1..=8u8 {
            assert_eq!(od.value(0x1003, sub), Some(0xFF0B - sub as u32));
        }
        assert_eq!(node.core().emcy.register(), GENERIC);
    }

    #[test]
    fn history_clear_and_read_rules() {
        let mut node = booted();
        set_error(node.split().1, 0xFF05, MANUFACTURER, true, Instant::ZERO);
        let core = node.split().1;
        assert_eq!(check_read(core, 0x1003, 0), Ok(()));
        assert_eq!(check_read(core, 0x1003, 1), Ok(()));
        assert_eq!(check_read(core, 0x1003, 2), Err(Abort::NO_DATA));
        assert_eq!(check_read(core, 0x1018, 2), Ok(()));
        let pos = core.od.pos(0x1003, 0).unwrap();
        assert_eq!(on_write(core, CoreHook::ErrorHistory, pos, 1, Instant::ZERO), Err(Abort::INVALID_VALUE));
        assert_eq!(on_write(core, CoreHook::ErrorHistory, pos, 0, Instant::ZERO), Ok(()));
        core.od.set(pos, 0);
        assert_eq!(core.od.value(0x1003, 1), Some(0));
        assert_eq!(check_read(core, 0x1003, 1), Err(Abort::NO_DATA));
        // Clearing the history does not clear the condition.
        assert_eq!(core.od.value(0x1001, 0), Some(0x81));
    }

    #[test]
    fn cob_id_rules() {
        assert_eq!(check_cob_id(0x81, 0x8000_0081), Ok(()));
        assert_eq!(check_cob_id(0x8000_0081, 0x8000_0090), Ok(()));
        assert_eq!(check_cob_id(0x8000_0090, 0x90), Ok(()));
        assert_eq!(check_cob_id(0x81, 0x81), Ok(()));
        assert_eq!(check_cob_id(0x81, 0x90), Err(Abort::INVALID_VALUE));
        assert_eq!(check_cob_id(0x8000_0081, 0x4000_0081), Err(Abort::INVALID_VALUE));
        assert_eq!(check_cob_id(0x8000_0081, 0x0000_0881), Err(Abort::INVALID_VALUE));
        assert_eq!(check_cob_id(0x8000_0081, 0x701), Err(Abort::INVALID_VALUE));
        assert_eq!(check_cob_id(0x8000_0081, 0x7F), Err(Abort::INVALID_VALUE));
        assert_eq!(check_cob_id(0x8000_0081, 0x2000_0001), Ok(()));
        assert_eq!(check_cob_id(0x8000_0081, 0xA123_4567), Ok(()));
    }

    #[test]
    fn no_emcy_in_stopped_or_with_invalid_cob_id() {
        let mut node = booted();
        let core = node.split().1;
        core.nmt = NmtState::Stopped;
        set_error(core, 0xFF05, MANUFACTURER, true, Instant::ZERO);
        assert_eq!(core.od.value(0x1001, 0), Some(0x81));
        assert_eq!(core.od.value(0x1003, 1), Some(0xFF05));
        core.nmt = NmtState::PreOperational;
        core.od.set_value(0x1014, 0, 0x8000_0081);
        set_error(core, 0xFF05, MANUFACTURER, false, Instant::ZERO);
        assert!(frames(&mut node).is_empty());
        assert_eq!(node.core().od.value(0x1001, 0), Some(0));
    }

    #[test]
    fn conditions_before_boot_up_follow_it() {
        let mut node = Node::new(T, 1, Bitrate::K500);
        set_error(node.split().1, 0xFF05, MANUFACTURER, true, Instant::ZERO);
        assert!(frames(&mut node).is_empty());
        node.poll(Instant::ZERO);
        assert_eq!(
            frames(&mut node).as_slice(),
            &[Frame::std(0x701, &[0]), Frame::std(0x81, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0])]
        );
    }
}
