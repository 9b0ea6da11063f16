//! EMCY producer (CiA 301 §7.2.7): the CANopen announcement of the error conditions the
//! context keeps ([`crate::errors`]: the conditions, 1001h and 1003h).
//!
//! The rules (decisions D-EMCY-n in `docs/decisions.md`):
//! - each change of a condition is one EMCY: its code on a rising condition, the "error reset"
//!   0000h on a falling one, with 1001h as the change left it;
//! - the frame is 8 bytes: code LSB first, 1001h, five manufacturer bytes 00h;
//! - EMCY frames go out in PRE-OPERATIONAL and OPERATIONAL only, and only while 1014h bit 31 is
//!   0; one that falls due in STOPPED or with an invalid COB-ID is dropped (1001h and 1003h
//!   still record it); one that falls due before the boot-up message is sent right after it;
//! - after an NMT reset every condition still active is announced again after the boot-up;
//! - no inhibit time: none of the manuals has 1015h.
//!
//! The node sets the context's announcement gate from its NMT state ([`gate`]) and gives it
//! the frame builder ([`frame`]); a condition's change is then sent, held or dropped at once.

use crate::abort::Abort;
use crate::context::Context;
use crate::errors::Gate;
use crate::frame::{CanId, Frame};
use crate::nmt::NmtState;
use crate::od::Od;
use crate::time::Instant;
use crate::wire::emcy::EmcyMessage;

pub use crate::errors::{ERROR_HISTORY, ERROR_REGISTER, GENERIC, MAX_ACTIVE, MAX_DEFERRED};
pub use crate::wire::emcy::NO_ERROR;

/// Index of the EMCY COB-ID.
pub const COB_ID_EMCY: u16 = 0x1014;
/// 1001h bit 4: communication error (error passive, bus-off).
pub const COMMUNICATION: u8 = 0x10;
/// 1001h bit 7: manufacturer-specific (the SIKO sensor errors).
pub const MANUFACTURER: u8 = 0x80;

const VALID_BIT: u32 = 1 << 31;
const RESERVED_BIT: u32 = 1 << 30;
const EXTENDED_BIT: u32 = 1 << 29;

/// Sets or clears the error condition `code`: [`Context::set_error`], kept here for the
/// devices and tests that name the producer.
pub fn set_error(ctx: &mut Context, code: u16, register_bits: u8, active: bool, now: Instant) {
    ctx.set_error(code, register_bits, active, now);
}

/// What an announcement does in NMT state `nmt`: sent in PRE-OPERATIONAL and OPERATIONAL,
/// held until the boot-up message in INITIALISATION, dropped in STOPPED.
pub const fn gate(nmt: NmtState) -> Gate {
    match nmt {
        NmtState::Initialising => Gate::Defer,
        NmtState::PreOperational | NmtState::Operational => Gate::Send,
        NmtState::Stopped => Gate::Drop,
    }
}

/// The EMCY frame of (code, register) for node `node_id`: on the identifier 1014h designates,
/// `None` while its valid bit says "does not exist". The node's [`crate::errors::Announce`].
pub fn frame(od: &Od, node_id: u8, code: u16, register: u8) -> Option<Frame> {
    let raw = od.value(COB_ID_EMCY, 0).unwrap_or(0x80 + node_id as u32);
    if raw & VALID_BIT != 0 {
        return None;
    }
    Some(Frame::new(CanId::from_cob_id(raw), &EmcyMessage::new(code, register).emit()))
}

/// Checks a write to 1014h (entry `pos`) in NMT state `nmt`; on `Ok` the node stores the
/// value.
///
/// CiA 301 §7.5.2.7 and the manuals' 1014h description: writable in PRE-OPERATIONAL only
/// (08000022h otherwise); bit 30 is always 0; an 11-bit identifier leaves bits 28..11 at 0;
/// the identifier may change only while the COB-ID is invalid (bit 31 = 1), in the written or
/// the stored value; a restricted identifier (CiA 301 table 70) is refused. Every refusal of a
/// value is 06090030h.
pub fn on_write_cob_id(od: &Od, nmt: NmtState, pos: usize, value: u32) -> Result<(), Abort> {
    if nmt != NmtState::PreOperational {
        return Err(Abort::DEVICE_STATE);
    }
    check_cob_id(od.get(pos), value)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::Bitrate;
    use crate::context::Output;
    use crate::devices::sgh10;
    use crate::errors;
    use crate::storage::{self, Loaded};

    /// The SGH10's dictionary in a context, node-ID 1, announcing EMCYs as a CANopen node in
    /// `nmt` does: no device, no node.
    fn ctx(nmt: NmtState) -> Context {
        let (od, storage, _) = storage::power_on(sgh10::TABLE, &Loaded::Blank, 1);
        let mut c = Context::new(od, storage, 1, Bitrate::K500);
        c.errors.announce_with(frame);
        c.errors.set_gate(gate(nmt));
        c
    }

    /// The frames sent so far.
    fn frames(ctx: &mut Context) -> heapless::Vec<Frame, 16> {
        let mut v = heapless::Vec::new();
        while let Some(o) = ctx.out.pop() {
            if let Output::Frame(f) = o {
                v.push(f).unwrap();
            }
        }
        v
    }

    const PRE: NmtState = NmtState::PreOperational;

    #[test]
    fn rising_and_falling_conditions() {
        let mut c = ctx(PRE);
        let now = Instant::ZERO;
        c.set_error(0xFF15, MANUFACTURER, true, now);
        c.set_error(0xFF15, MANUFACTURER, true, now);
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0x15, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
        c.set_error(0x8120, COMMUNICATION, true, now);
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0x20, 0x81, 0x91, 0, 0, 0, 0, 0])]);
        c.set_error(0xFF15, MANUFACTURER, false, now);
        c.set_error(0xFF15, MANUFACTURER, false, now);
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0, 0, 0x11, 0, 0, 0, 0, 0])]);
        set_error(&mut c, 0x8120, COMMUNICATION, false, now);
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0, 0, 0, 0, 0, 0, 0, 0])]);
        let od = &c.od;
        assert_eq!(od.value(0x1001, 0), Some(0));
        assert_eq!(
            (od.value(0x1003, 0), od.value(0x1003, 1), od.value(0x1003, 2)),
            (Some(2), Some(0x8120), Some(0xFF15))
        );
        c.set_error(0, MANUFACTURER, true, now);
        assert!(frames(&mut c).is_empty());
    }

    #[test]
    fn history_keeps_the_newest_eight() {
        let mut c = ctx(PRE);
        for code in 1..=10u16 {
            c.set_error(0xFF00 + code, 0, true, Instant::ZERO);
        }
        let od = &c.od;
        assert_eq!(od.value(0x1003, 0), Some(8));
        for sub in 1..=8u8 {
            assert_eq!(od.value(0x1003, sub), Some(0xFF0B - sub as u32));
        }
        assert_eq!(c.errors.register(), GENERIC);
    }

    #[test]
    fn history_clear_and_read_rules() {
        let mut c = ctx(PRE);
        c.set_error(0xFF05, MANUFACTURER, true, Instant::ZERO);
        assert_eq!(errors::check_read(&c.od, 0x1003, 0), Ok(()));
        assert_eq!(errors::check_read(&c.od, 0x1003, 1), Ok(()));
        assert_eq!(errors::check_read(&c.od, 0x1003, 2), Err(Abort::NO_DATA));
        assert_eq!(errors::check_read(&c.od, 0x1018, 2), Ok(()));
        let pos = c.od.pos(0x1003, 0).unwrap();
        assert_eq!(errors::clear_history(&mut c.od, pos, 1), Err(Abort::INVALID_VALUE));
        assert_eq!(errors::clear_history(&mut c.od, pos, 0), Ok(()));
        c.od.set(pos, 0);
        assert_eq!(c.od.value(0x1003, 1), Some(0));
        assert_eq!(errors::check_read(&c.od, 0x1003, 1), Err(Abort::NO_DATA));
        // Clearing the history does not clear the condition.
        assert_eq!(c.od.value(0x1001, 0), Some(0x81));
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
        let c = ctx(PRE);
        let pos = c.od.pos(COB_ID_EMCY, 0).unwrap();
        assert_eq!(on_write_cob_id(&c.od, NmtState::Operational, pos, 0x8000_0081), Err(Abort::DEVICE_STATE));
        assert_eq!(on_write_cob_id(&c.od, PRE, pos, 0x8000_0081), Ok(()));
    }

    #[test]
    fn no_emcy_in_stopped_or_with_invalid_cob_id() {
        let mut c = ctx(NmtState::Stopped);
        c.set_error(0xFF05, MANUFACTURER, true, Instant::ZERO);
        assert!(frames(&mut c).is_empty());
        assert_eq!(c.od.value(0x1001, 0), Some(0x81));
        assert_eq!(c.od.value(0x1003, 1), Some(0xFF05));
        c.errors.set_gate(gate(PRE));
        c.od.set_value(0x1014, 0, 0x8000_0081);
        c.set_error(0xFF05, MANUFACTURER, false, Instant::ZERO);
        assert!(frames(&mut c).is_empty());
        assert_eq!(c.od.value(0x1001, 0), Some(0));
    }

    #[test]
    fn conditions_before_boot_up_follow_it_and_resets_announce_them_again() {
        let mut c = ctx(NmtState::Initialising);
        c.set_error(0xFF05, MANUFACTURER, true, Instant::ZERO);
        c.release_deferred();
        assert!(frames(&mut c).is_empty());
        c.errors.set_gate(gate(PRE));
        c.release_deferred();
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
        c.errors.defer_active();
        c.release_deferred();
        assert_eq!(frames(&mut c).as_slice(), &[Frame::std(0x81, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
    }
}
