//! EMCY producer (CiA 301 §7.2.7), the 1001h error register and the 1003h error history.

use crate::node::Core;
use crate::time::Instant;

/// EMCY producer state.
#[derive(Clone, Default)]
pub struct Emcy {}

/// Clears the producer's state after a reset communication.
pub fn reset(core: &mut Core) {
    let _ = core;
}

/// Runs due work (deferred EMCY frames).
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}
