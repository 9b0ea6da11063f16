//! The SGH50 draw-wire encoder board: the common MCU part, the angle sensor on the wire drum and
//! the straps that say which SGH50 it is (strap 0 fitted = redundant version, strap 1 fitted =
//! its second channel). The redundant SGH50 is two of these boards, one per channel, each a
//! CANopen node of its own running the same firmware.

use od_core::devices::sgh50::Variant;

use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, WireSensor};

/// Wire per drum turn: 250 mm, so the 7384 mm measuring range is under 30 turns.
pub const DRUM_UM_PER_TURN: u32 = 250_000;

/// The SGH50 board (one channel).
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// Single, or one channel of the redundant version, from the straps.
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
        variant: straps.sgh50(),
        io: WireSensor::new(sensor, DRUM_UM_PER_TURN),
    }
}
