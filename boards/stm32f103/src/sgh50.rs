//! The SGH50 draw-wire encoder board ([`crate::wire`]): strap 0 fitted = the redundant version,
//! strap 1 fitted = its second channel. The redundant SGH50 is two of these boards, one per
//! channel, each a CANopen node of its own running the same firmware.

use board_plan::straps::Straps;
use od_core::devices::sgh50::Variant;

use crate::wire::{self, WireBoard};

/// Wire per drum turn: 250 mm, so the 7384 mm measuring range is under 30 turns.
pub const DRUM_UM_PER_TURN: u32 = 250_000;

/// The SGH50 board (one channel).
pub type Board = WireBoard<Variant>;

/// Initialises the MCU (clocks) and takes the board's peripherals.
pub fn take() -> Board {
    wire::take(Straps::sgh50, DRUM_UM_PER_TURN)
}
