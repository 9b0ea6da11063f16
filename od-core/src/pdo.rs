//! SYNC consumer and PDOs (CiA 301 §7.2.2, §7.2.5): transmit PDOs on SYNC, timer and RTR,
//! receive PDOs into the mapped entries.

use crate::abort::Abort;
use crate::frame::Frame;
use crate::node::Core;
use crate::od::CoreHook;
use crate::time::Instant;

/// What a received frame was for the PDO layer.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum PdoEvent {
    /// Not a PDO or SYNC frame.
    None,
    /// A SYNC was consumed.
    Sync,
    /// RPDO `n` (0-based) was written into the dictionary.
    Rpdo(u8),
    /// A TPDO was requested by RTR and sent.
    Rtr,
}

/// PDO and SYNC state.
#[derive(Clone, Default)]
pub struct Pdos {}

/// Re-reads the PDO configuration from the dictionary (boot, reset communication).
pub fn reset(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// Handles a frame that may be a SYNC, an RPDO or a TPDO remote request.
pub fn on_frame(core: &mut Core, frame: &Frame, now: Instant) -> PdoEvent {
    let _ = (core, frame, now);
    PdoEvent::None
}

/// Sends event-timer TPDOs when due.
pub fn poll(core: &mut Core, now: Instant) {
    let _ = (core, now);
}

/// When the next event-timer TPDO is due.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    let _ = core;
    None
}

/// Checks a write to 1005h or a PDO parameter (entry `pos`, rule `hook`); on `Ok` the node
/// stores the value.
pub fn on_write(core: &mut Core, hook: CoreHook, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
    let _ = (core, hook, pos, value, now);
    Ok(())
}
