//! The boards' plain GPIO pins (the transceiver's standby, LEDs, the termination switch, the
//! straps) through the port registers (RM0008 9.2): the pin modes Embassy's `Output`, `Input`
//! and their drop gave them, in a fraction of the code. The pins still come as `Peri`
//! arguments, so no other driver can take them.

use embassy_stm32::gpio::{AnyPin, Pin};
use embassy_stm32::pac::gpio::Gpio;
use embassy_stm32::Peri;

/// CNF and MODE of a push-pull output at 2 MHz (Embassy's `Speed::Low`).
const OUTPUT_2MHZ: u32 = 0b0010;
/// CNF and MODE of an input with pull-up or pull-down (ODR selects which).
const INPUT_PULL: u32 = 0b1000;
/// CNF and MODE of an analog input: the pin draws nothing (a released pin, as Embassy leaves it).
const ANALOG: u32 = 0b0000;

/// Sets pin `n` of `port` to the CNF and MODE bits `mode` (CRL or CRH). Only the main task
/// configures pins, never an interrupt, so the read-modify-write needs no critical section.
fn configure(port: Gpio, n: u8, mode: u32) {
    let shift = (n % 8) as usize * 4;
    port.cr(n as usize / 8).modify(|w| w.0 = w.0 & !(0xF << shift) | mode << shift);
}

/// Drives pin `n` of `port` high or low (BSRR: set bits 0..15, reset bits 16..31).
fn drive(port: Gpio, n: u8, high: bool) {
    port.bsrr().write(|w| w.0 = 1 << (n + if high { 0 } else { 16 }));
}

/// A push-pull output at 2 MHz.
pub struct OutPin {
    port: Gpio,
    n: u8,
}

impl OutPin {
    /// `pin` as an output at `high`: the level is set before the pin drives it.
    pub fn new(pin: Peri<'static, AnyPin>, high: bool) -> OutPin {
        let (port, n) = (pin.block(), pin.pin());
        drive(port, n, high);
        configure(port, n, OUTPUT_2MHZ);
        OutPin { port, n }
    }

    /// Drives the pin high or low.
    pub fn set(&mut self, high: bool) {
        drive(self.port, self.n, high);
    }
}

/// Reads `pins` once with their pull-ups on, `settle` after switching them on, and releases
/// them (analog input) afterwards; bit k of the result is pin k's level.
pub fn read_pulled_up(pins: &[Peri<'_, AnyPin>], settle: embassy_time::Duration) -> u8 {
    for p in pins {
        drive(p.block(), p.pin(), true);
        configure(p.block(), p.pin(), INPUT_PULL);
    }
    embassy_time::block_for(settle);
    let mut levels = 0;
    for (k, p) in pins.iter().enumerate() {
        if p.block().idr().read().0 & 1 << p.pin() != 0 {
            levels |= 1 << k;
        }
        configure(p.block(), p.pin(), ANALOG);
    }
    levels
}
