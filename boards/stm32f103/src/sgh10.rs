//! The SGH10 / SGH10L draw-wire encoder board: the common MCU part, the angle sensor on the
//! wire drum, the variant strap (strap 0 fitted = SGH10L). No LEDs.

use od_core::devices::sgh10::Variant;

use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, WireSensor};

/// Wire per drum turn: 100 mm, so the 1023.9 mm measuring range is a little over 10 turns.
pub const DRUM_UM_PER_TURN: u32 = 100_000;

/// The SGH10 board.
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// SGH10 or SGH10L, from the straps.
    pub variant: Variant,
    /// The wire-length sensor.
    pub io: WireSensor,
}

/// Initialises the MCU (clocks) and takes the board's peripherals.
pub fn take() -> Board {
    let p = embassy_stm32::init(mcu::config());
    let straps = mcu::read_straps([p.PB12.into(), p.PB13.into(), p.PB14.into(), p.PB15.into()]);
    let sensor = AngleSensor::new(p.SPI1, p.PA4, p.PA5, p.PA6, p.PA7);
    Board {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        variant: straps.sgh10(),
        io: WireSensor::new(sensor, DRUM_UM_PER_TURN),
    }
}
