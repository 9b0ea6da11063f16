//! The SGH50 draw-wire encoder board ([`crate::wire`]): strap 0 fitted = the redundant version,
//! strap 1 fitted = its second channel. The redundant SGH50 is two of these boards, one per
//! channel, each a CANopen node of its own running the same firmware. PB0 drives the internal
//! CAN bus termination switch (120 Ω between CAN_H and CAN_L, active high), which follows 5F09h
//! (D-SGH50-5).

use board_plan::straps::Straps;
use embassy_stm32::peripherals::PB0;
use embassy_stm32::Peri;
use od_core::devices::sgh50::{self, Sgh50, Variant};
use od_core::node::Core;
use od_core::Instant;

use crate::pin::OutPin;
use crate::sensor::WireSensor;
use crate::wire::{self, WireBoard};
use crate::Io;

/// Wire per drum turn: 250 mm, so the 7384 mm measuring range is under 30 turns.
pub const DRUM_UM_PER_TURN: u32 = 250_000;

/// The SGH50's inputs and outputs: the wire sensor and the bus termination switch.
pub struct Sgh50Io {
    sensor: WireSensor,
    termination: OutPin,
}

impl Sgh50Io {
    /// The sensor, and the termination switch on PB0, off until the node's value is shown.
    pub fn new(sensor: WireSensor, termination: Peri<'static, PB0>) -> Sgh50Io {
        Sgh50Io { sensor, termination: OutPin::new(termination.into(), false) }
    }
}

impl Io<Sgh50> for Sgh50Io {
    fn period_us(&self, device: &Sgh50) -> u32 {
        Io::<Sgh50>::period_us(&self.sensor, device)
    }

    fn sample(&mut self, device: &mut Sgh50, core: &mut Core, now: Instant) {
        self.sensor.sample(device, core, now);
    }

    /// Switches the termination as 5F09h says, at every turn of the loop: a write takes effect
    /// in the turn that handles it.
    fn show(&mut self, _: &Sgh50, core: &Core, _: Instant) -> Option<Instant> {
        self.termination.set(sgh50::bus_termination(core));
        None
    }
}

/// The SGH50 board (one channel).
pub type Board = WireBoard<Variant, Sgh50Io>;

/// Initialises the MCU (clocks) and takes the board's peripherals.
pub fn take() -> Board {
    wire::take(Straps::sgh50, DRUM_UM_PER_TURN, Sgh50Io::new)
}
