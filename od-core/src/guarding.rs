//! Node guarding and life guarding (100Ch, 100Dh).

use crate::abort::Abort;
use crate::frame::Frame;
use crate::node::Core;
use crate::time::Instant;

/// Node/life guarding state.
#[derive(Clone, Default)]
pub struct Guarding {}

/// Restarts guarding (after boot-up).
pub fn reset(core: &mut Core) {
    let _ = core;
}

/// Answers a guarding RTR on 700h + node-ID.
pub fn on_rtr(core: &mut Core, frame: &Frame, now: Instant) {
    let _ = (core, frame, now);
}

/// Detects an expired life time.
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// When the life time next expires.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    let _ = core;
    None
}

/// Checks a write to 100Ch/100Dh (entry `pos`); on `Ok` the node stores the value.
pub fn on_write(core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
    let _ = (core, pos, value, now);
    Ok(())
}
