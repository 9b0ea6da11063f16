//! EMCY producer (CiA 301 §7.2.7), the 1001h error register and the 1003h error history.

use crate::abort::Abort;
use crate::node::Core;
use crate::od::CoreHook;
use crate::time::Instant;

/// EMCY producer state.
#[derive(Clone, Default)]
pub struct Emcy {}

/// Sets or clears the error condition `code` (for example FF15h, 8120h).
///
/// On a rising condition the node sends one EMCY with `code`, sets `register_bits` in 1001h
/// (bit 0 is implied) and enters the code in the 1003h history. On a falling condition it sends
/// the "error reset" EMCY 0000h and recomputes 1001h from the errors still active. Calling it
/// again with the same state does nothing ("only once per error event").
pub fn set_error(core: &mut Core, code: u16, register_bits: u8, active: bool, now: Instant) {
    let _ = (core, code, register_bits, active, now);
}

/// Clears the producer's state after a reset communication.
pub fn reset(core: &mut Core) {
    let _ = core;
}

/// Runs due work (deferred EMCY frames).
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// Checks a write to 1003h sub 0 (only 0, which clears the history) or 1014h; on `Ok` the
/// node stores the value.
pub fn on_write(core: &mut Core, hook: CoreHook, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
    let _ = (core, hook, pos, value, now);
    Ok(())
}

/// Refuses reads the dictionary alone cannot judge (1003h subs above the error count).
pub fn check_read(core: &Core, index: u16, sub: u8) -> Result<(), Abort> {
    let _ = (core, index, sub);
    Ok(())
}
