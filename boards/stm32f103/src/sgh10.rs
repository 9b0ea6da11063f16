//! The SGH10 / SGH10L draw-wire encoder board ([`crate::wire`]): strap 0 fitted = SGH10L.

use board_plan::straps::Straps;
use od_core::devices::sgh10::Variant;

use crate::wire::{self, WireBoard};

/// Wire per drum turn: 100 mm, so the 1023.9 mm measuring range is a little over 10 turns.
pub const DRUM_UM_PER_TURN: u32 = 100_000;

/// The SGH10 board.
pub type Board = WireBoard<Variant>;

/// Initialises the MCU (clocks) and takes the board's peripherals. The SGH10 has no bus
/// termination switch: PB0 stays an input, as after reset.
pub fn take() -> Board {
    wire::take(Straps::sgh10, DRUM_UM_PER_TURN, |sensor, _| sensor)
}
