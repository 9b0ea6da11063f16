//! Heartbeat producer (1017h).

use crate::abort::Abort;
use crate::node::Core;
use crate::time::Instant;

/// Heartbeat producer state.
#[derive(Clone, Default)]
pub struct Heartbeat {}

/// Restarts the producer (after boot-up).
pub fn reset(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// Sends the heartbeat when due.
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// When the next heartbeat is due.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    let _ = core;
    None
}

/// Checks a write to 1017h; on `Ok` the node stores the value.
pub fn on_write(core: &mut Core, value: u32, now: Instant) -> Result<(), Abort> {
    let _ = (core, value, now);
    Ok(())
}
