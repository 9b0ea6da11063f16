//! The draw-wire encoder board the SGH10 and the SGH50 share: the common MCU part, the angle
//! sensor on the wire drum, the variant straps, and PB0 for the SGH50's bus termination switch
//! (left unconnected on the SGH10). No LEDs. The products differ in how they read their straps,
//! in the wire their drum pays out per turn and in what they do with PB0.

use board_plan::straps::Straps;
use embassy_stm32::peripherals::PB0;
use embassy_stm32::Peri;

use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, WireSensor};

/// A draw-wire encoder board whose straps select a `V`, with inputs and outputs `I`.
pub struct WireBoard<V, I = WireSensor> {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// The product variant, from the straps.
    pub variant: V,
    /// The wire-length sensor and the product's outputs.
    pub io: I,
}

/// Initialises the MCU (clocks) and takes the board's peripherals: the variant as `variant`
/// reads the straps, a drum paying out `um_per_turn` micrometres of wire per turn, and the
/// product's inputs and outputs as `io` makes them of the sensor and PB0.
pub fn take<V, I>(
    variant: fn(Straps) -> V,
    um_per_turn: u32,
    io: impl FnOnce(WireSensor, Peri<'static, PB0>) -> I,
) -> WireBoard<V, I> {
    let p = embassy_stm32::init(mcu::config());
    let straps = mcu::read_straps([p.PB12.into(), p.PB13.into(), p.PB14.into(), p.PB15.into()]);
    let sensor = AngleSensor::new(p.SPI1, p.PA4, p.PA5, p.PA6, p.PA7);
    WireBoard {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        variant: variant(straps),
        io: io(WireSensor::new(sensor, um_per_turn), p.PB0),
    }
}
