//! The encoders' position sensor: an absolute magnetic angle sensor with a multiturn counter on
//! SPI1 (NSS PA4, SCK PA5, MISO PA6, MOSI PA7), read as a 5-byte frame that
//! `board_plan::sensor` decodes.

use board_plan::sensor::{decode, wire_raw_um, Reading, FRAME_LEN};
use embassy_stm32::pac::{self, spi::vals as spi_vals};
use embassy_stm32::peripherals::{PA4, PA5, PA6, PA7, SPI1};
use embassy_stm32::rcc::enable_and_reset_without_stop;
use embassy_stm32::Peri;
use od_core::encoder::{Encoder, SensorFault};
use od_core::node::Core;
use od_core::Instant;

use crate::Io;

/// SPI clock: APB2 72 MHz / 64. A 5-byte frame takes 36 µs, far inside the 1 ms sample period.
pub const SPI_HZ: u32 = 1_125_000;

/// SPI_CR1.BR for [`SPI_HZ`]: the clock divided by 2 << 5 = 64.
const SPI_BR: u8 = 5;
const _: () = assert!(72_000_000 / (2 << SPI_BR) == SPI_HZ);

/// A position sensor as the encoders read it: one absolute reading (turns and angle) per call,
/// or why there is none. The boards' SPI sensor is [`AngleSensor`]; another front-end (a
/// different chip, a test double) implements this and nothing else changes.
pub trait PositionSensor {
    /// Reads the sensor once.
    fn read(&mut self) -> Result<Reading, SensorFault>;
}

/// The angle sensor on SPI1, through its registers (master, mode 1, 8 bits, most significant
/// bit first, APB2 / 64, software NSS on PA4): the configuration, pins and byte sequence of
/// Embassy's blocking driver, in a fraction of its code (as the AP10T's LCD, D-FW-16).
pub struct AngleSensor(());

impl AngleSensor {
    /// The sensor on SPI1. MISO has a pull-up: a missing sensor reads all FFh, which
    /// [`decode`] reports as [`SensorFault::NoResponse`].
    pub fn new(
        _spi: Peri<'static, SPI1>,
        _nss: Peri<'static, PA4>,
        _sck: Peri<'static, PA5>,
        _miso: Peri<'static, PA6>,
        _mosi: Peri<'static, PA7>,
    ) -> AngleSensor {
        // NSS high (deselected) and MISO's pull-up selected (ODR = 1) before the pins change.
        pac::GPIOA.bsrr().write(|w| w.0 = 1 << 4 | 1 << 6);
        // PA4 (NSS) push-pull output at 10 MHz (MODE 01, CNF 00), PA5 (SCK) and PA7 (MOSI)
        // alternate function push-pull at 50 MHz (MODE 11, CNF 10), PA6 (MISO) input with
        // pull-up (MODE 00, CNF 10).
        pac::GPIOA.cr(0).modify(|w| w.0 = w.0 & !0xFFFF_0000 | 0xB8B1_0000);
        enable_and_reset_without_stop::<SPI1>();
        pac::SPI1.cr2().write(|w| w.set_ssoe(true));
        pac::SPI1.cr1().write(|w| {
            w.set_cpha(spi_vals::Cpha::SECOND_EDGE);
            w.set_mstr(spi_vals::Mstr::MASTER);
            w.set_br(spi_vals::Br::from_bits(SPI_BR));
            w.set_ssm(true);
            w.set_ssi(true);
            w.set_spe(true);
        });
        AngleSensor(())
    }
}

impl PositionSensor for AngleSensor {
    /// Reads one frame (NSS low, each byte sent as 00h and the answer read, NSS high). An
    /// overrun or mode fault of the SPI counts as no response.
    fn read(&mut self) -> Result<Reading, SensorFault> {
        let spi = pac::SPI1;
        let mut frame = [0u8; FRAME_LEN];
        while spi.sr().read().rxne() {
            let _ = spi.dr().read();
        }
        pac::GPIOA.brr().write(|w| w.0 = 1 << 4);
        for b in frame.iter_mut() {
            *b = crate::mcu::spi_exchange(spi, 0);
        }
        pac::GPIOA.bsrr().write(|w| w.0 = 1 << 4);
        let sr = spi.sr().read();
        if sr.ovr() || sr.modf() {
            return Err(SensorFault::NoResponse);
        }
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
