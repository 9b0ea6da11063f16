//! EMCY producer (CiA 301 §7.2.7), the 1001h error register and the 1003h error history.

use crate::node::Core;
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
