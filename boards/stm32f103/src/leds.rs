//! The rotary encoders' three status LEDs (WV5800M, WV58MR): green PB0, red PB1, yellow PB10,
//! active high, switched together through port B's set/reset register.

use embassy_stm32::pac;
use embassy_stm32::peripherals::{PB0, PB1, PB10};
use embassy_stm32::Peri;
use od_core::led::Lit;

use crate::pin::OutPin;

/// The LEDs' pins on port B: green, red, yellow.
const PINS: [u8; 3] = [0, 1, 10];

/// The three LEDs.
pub struct StatusLeds(());

impl StatusLeds {
    /// The LEDs, all off: push-pull outputs at 2 MHz, low.
    pub fn new(green: Peri<'static, PB0>, red: Peri<'static, PB1>, yellow: Peri<'static, PB10>) -> StatusLeds {
        OutPin::new(green.into(), false);
        OutPin::new(red.into(), false);
        OutPin::new(yellow.into(), false);
        StatusLeds(())
    }

    /// Lights the LEDs `lit` names: one write sets the lit ones and resets the others.
    pub fn set(&mut self, lit: Lit) {
        let mut bsrr = 0;
        for (pin, on) in PINS.into_iter().zip([lit.green, lit.red, lit.yellow]) {
            bsrr |= 1 << (pin + if on { 0 } else { 16 });
        }
        pac::GPIOB.bsrr().write(|w| w.0 = bsrr);
    }
}
