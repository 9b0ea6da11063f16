//! The WV58MR / WH58MR redundant rotary encoder board (SAE J1939): the common MCU part, the
//! angle sensor with its turn counter, the three status LEDs, and the straps (strap 0 fitted =
//! redundant version, strap 1 fitted = its second channel). The redundant encoder is two of
//! these boards, one per channel, each a J1939 node of its own; the turns, like the WV5800M's,
//! are the firmware image's.
//!
//! The J1939 device is `od_core::devices::wv58mr::Wv58mr` on a `J1939Node`; [`ChannelIo`]
//! feeds it the same raw multiturn count as the WV5800M's sensor gives and shows its LEDs.

use board_plan::sensor::multiturn_raw;
use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::Wv58mr;
use od_core::encoder::Encoder;
use od_core::node::Core;
use od_core::Instant;

use crate::leds::StatusLeds;
use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, PositionSensor};
use crate::Io;

/// One channel's inputs and outputs: the shaft sensor and the three LEDs.
pub struct ChannelIo<S = AngleSensor> {
    sensor: S,
    leds: StatusLeds,
    turn_bits: u32,
}

impl<S: PositionSensor> ChannelIo<S> {
    /// The sensor counting `revolutions` turns (a power of two, 1 = singleturn) and the LEDs.
    pub fn new(sensor: S, leds: StatusLeds, revolutions: u32) -> ChannelIo<S> {
        ChannelIo { sensor, leds, turn_bits: revolutions.trailing_zeros() }
    }
}

impl<S: PositionSensor> Io<Wv58mr> for ChannelIo<S> {
    fn period_us(&self, device: &Wv58mr) -> u32 {
        device.sample_period_us()
    }

    fn sample(&mut self, device: &mut Wv58mr, core: &mut Core, now: Instant) {
        let raw = self.sensor.read().map(|r| multiturn_raw(r, self.turn_bits));
        device.on_sample(core, raw, now);
    }

    fn show(&mut self, device: &Wv58mr, _: &Core, now: Instant) -> Option<Instant> {
        let leds = device.leds();
        self.leds.set(leds.lit(now));
        leds.next_change(now)
    }
}

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
    /// Sensor and LEDs.
    pub io: ChannelIo,
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
        io: ChannelIo::new(
            AngleSensor::new(p.SPI1, p.PA4, p.PA5, p.PA6, p.PA7),
            StatusLeds::new(p.PB0, p.PB1, p.PB10),
            turns.revolutions(),
        ),
    }
}
