//! The WV58MR / WH58MR redundant rotary encoder board (SAE J1939): the common MCU part, the
//! angle sensor with its turn counter, the three status LEDs, and the straps (strap 0 fitted =
//! redundant version, strap 1 fitted = its second channel). The redundant encoder is two of
//! these boards, one per channel, each a J1939 node of its own; the turns, like the WV5800M's,
//! are the firmware image's.
//!
//! The J1939 device is not in the core yet; this module is the board it will run on: its
//! sensor gives the same raw multiturn count as the WV5800M's ([`Board::raw`]).

use board_plan::sensor::multiturn_raw;
use od_core::devices::wv5800m::Turns;
use od_core::encoder::SensorFault;

use crate::leds::StatusLeds;
use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, PositionSensor};

/// The WV58MR board (one channel).
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// The measuring range.
    pub turns: Turns,
    /// The redundant version?
    pub redundant: bool,
    /// Its second channel?
    pub second_channel: bool,
    /// The shaft sensor.
    pub sensor: AngleSensor,
    /// The status LEDs.
    pub leds: StatusLeds,
}

impl Board {
    /// One sensor reading as the raw count (16384 steps a turn, the turns modulo the range).
    pub fn raw(&mut self) -> Result<u32, SensorFault> {
        let bits = self.turns.revolutions().trailing_zeros();
        self.sensor.read().map(|r| multiturn_raw(r, bits))
    }
}

/// Initialises the MCU (clocks) and takes the board's peripherals for an encoder of `turns`.
pub fn take(turns: Turns) -> Board {
    let p = embassy_stm32::init(mcu::config());
    let straps = mcu::read_straps([p.PB12.into(), p.PB13.into(), p.PB14.into(), p.PB15.into()]);
    let (redundant, second_channel) = straps.wv58mr();
    Board {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        turns,
        redundant,
        second_channel,
        sensor: AngleSensor::new(p.SPI1, p.PA4, p.PA5, p.PA6, p.PA7),
        leds: StatusLeds::new(p.PB0, p.PB1, p.PB10),
    }
}
