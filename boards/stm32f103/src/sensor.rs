//! The encoders' position sensor: an absolute magnetic angle sensor with a multiturn counter on
//! SPI1 (NSS PA4, SCK PA5, MISO PA6, MOSI PA7), read as a 5-byte frame that
//! `board_plan::sensor` decodes.

use board_plan::sensor::{decode, wire_raw_um, Reading, FRAME_LEN};
use embassy_stm32::gpio::{Level, Output, Pull, Speed};
use embassy_stm32::mode::Blocking;
use embassy_stm32::peripherals::{PA4, PA5, PA6, PA7, SPI1};
use embassy_stm32::spi::{self, Spi, MODE_1};
use embassy_stm32::time::Hertz;
use embassy_stm32::Peri;
use od_core::encoder::{Encoder, SensorFault};
use od_core::node::Core;
use od_core::Instant;

use crate::Io;

/// SPI clock: APB2 72 MHz / 64. A 5-byte frame takes 36 µs, far inside the 1 ms sample period.
pub const SPI_HZ: u32 = 1_125_000;

/// A position sensor as the encoders read it: one absolute reading (turns and angle) per call,
/// or why there is none. The boards' SPI sensor is [`AngleSensor`]; another front-end (a
/// different chip, a test double) implements this and nothing else changes.
pub trait PositionSensor {
    /// Reads the sensor once.
    fn read(&mut self) -> Result<Reading, SensorFault>;
}

/// The angle sensor on SPI1.
pub struct AngleSensor {
    spi: Spi<'static, Blocking, spi::mode::Master>,
    nss: Output<'static>,
}

impl AngleSensor {
    /// The sensor on SPI1. MISO has a pull-up: a missing sensor reads all FFh, which
    /// [`decode`] reports as [`SensorFault::NoResponse`].
    pub fn new(
        spi: Peri<'static, SPI1>,
        nss: Peri<'static, PA4>,
        sck: Peri<'static, PA5>,
        miso: Peri<'static, PA6>,
        mosi: Peri<'static, PA7>,
    ) -> AngleSensor {
        let mut config = spi::Config::default();
        config.mode = MODE_1;
        config.frequency = Hertz(SPI_HZ);
        config.miso_pull = Pull::Up;
        AngleSensor {
            spi: Spi::new_blocking(spi, sck, mosi, miso, config),
            nss: Output::new(nss, Level::High, Speed::Medium),
        }
    }
}

impl PositionSensor for AngleSensor {
    /// Reads one frame. A bus error of the SPI counts as no response.
    fn read(&mut self) -> Result<Reading, SensorFault> {
        let mut frame = [0u8; FRAME_LEN];
        self.nss.set_low();
        let result = self.spi.blocking_transfer_in_place(&mut frame);
        self.nss.set_high();
        result.map_err(|_| SensorFault::NoResponse)?;
        decode(&frame)
    }
}

/// The wire encoders' sensor input: the drum's turns and angle as the pulled-out wire length in
/// micrometres (the raw value of their 600Ch), sampled every device sample period.
pub struct WireSensor<S = AngleSensor> {
    sensor: S,
    um_per_turn: u32,
}

impl<S: PositionSensor> WireSensor<S> {
    /// `sensor` on a drum that pays out `um_per_turn` micrometres of wire per turn.
    pub fn new(sensor: S, um_per_turn: u32) -> WireSensor<S> {
        WireSensor { sensor, um_per_turn }
    }
}

impl<E: Encoder, S: PositionSensor> Io<E> for WireSensor<S> {
    fn period_us(&self, device: &E) -> u32 {
        device.sample_period_us()
    }

    fn sample(&mut self, device: &mut E, core: &mut Core, now: Instant) {
        let raw = self.sensor.read().map(|r| wire_raw_um(r, self.um_per_turn));
        device.on_sample(core, raw, now);
    }

    fn show(&mut self, _: &E, _: &Core, _: Instant) -> Option<Instant> {
        None
    }
}
