//! The WV5800M / WH5800M multiturn rotary encoder board: the common MCU part, the angle sensor
//! on the shaft with its turn counter and the three status LEDs. Which variant it is (model and
//! turns) is the firmware image's: each variant has its own dictionary.

use board_plan::sensor::multiturn_raw;
use od_core::devices::wv5800m::{Variant, Wv5800m};
use od_core::encoder::Encoder;
use od_core::node::Core;
use od_core::Instant;

use crate::leds::StatusLeds;
use crate::mcu::{self, Mcu};
use crate::sensor::{AngleSensor, PositionSensor};
use crate::Io;

/// The rotary encoder's inputs and outputs: the shaft sensor and the LEDs.
pub struct RotaryIo<S = AngleSensor> {
    sensor: S,
    leds: StatusLeds,
    turn_bits: u32,
}

impl<S: PositionSensor> RotaryIo<S> {
    /// The sensor counting `revolutions` turns (a power of two, 1 = singleturn) and the LEDs.
    pub fn new(sensor: S, leds: StatusLeds, revolutions: u32) -> RotaryIo<S> {
        RotaryIo { sensor, leds, turn_bits: revolutions.trailing_zeros() }
    }
}

impl<S: PositionSensor> Io<Wv5800m> for RotaryIo<S> {
    fn period_us(&self, device: &Wv5800m) -> u32 {
        device.sample_period_us()
    }

    fn sample(&mut self, device: &mut Wv5800m, core: &mut Core, now: Instant) {
        let raw = self.sensor.read().map(|r| multiturn_raw(r, self.turn_bits));
        device.on_sample(core, raw, now);
    }

    fn show(&mut self, device: &Wv5800m, _: &Core, now: Instant) -> Option<Instant> {
        let leds = device.leds();
        self.leds.set(leds.lit(now));
        leds.next_change(now)
    }
}

/// The WV5800M board.
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// Sensor and LEDs.
    pub io: RotaryIo,
}

/// Initialises the MCU (clocks) and takes the board's peripherals for an encoder of `variant`.
pub fn take(variant: Variant) -> Board {
    let p = embassy_stm32::init(mcu::config());
    let sensor = AngleSensor::new(p.SPI1, p.PA4, p.PA5, p.PA6, p.PA7);
    let leds = StatusLeds::new(p.PB0, p.PB1, p.PB10);
    Board {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        io: RotaryIo::new(sensor, leds, variant.turns.revolutions()),
    }
}
