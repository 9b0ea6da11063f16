//! LSS slave (CiA 305) on 7E5h (master to slave) / 7E4h (slave to master).

use crate::frame::Frame;
use crate::node::Core;
use crate::time::Instant;

/// LSS master-to-slave identifier.
pub const RX_ID: u16 = 0x7E5;
/// LSS slave-to-master identifier.
pub const TX_ID: u16 = 0x7E4;

/// LSS slave state.
#[derive(Clone, Default)]
pub struct Lss {}

/// Handles a frame on 7E5h.
pub fn on_frame(core: &mut Core, frame: &Frame, now: Instant) {
    let _ = (core, frame, now);
}

/// Runs the bit-rate switch delays.
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// When the next LSS delay ends.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    let _ = core;
    None
}
