//! The rotary encoders' three status LEDs (WV5800M, WV58MR): green PB0, red PB1, yellow PB10,
//! active high.

use embassy_stm32::gpio::{AnyPin, Level, Output, Speed};
use embassy_stm32::peripherals::{PB0, PB1, PB10};
use embassy_stm32::Peri;
use od_core::led::Lit;

/// The three LEDs.
pub struct StatusLeds {
    green: Output<'static>,
    red: Output<'static>,
    yellow: Output<'static>,
}

impl StatusLeds {
    /// The LEDs, all off.
    pub fn new(green: Peri<'static, PB0>, red: Peri<'static, PB1>, yellow: Peri<'static, PB10>) -> StatusLeds {
        let off = |p: Peri<'static, AnyPin>| Output::new(p, Level::Low, Speed::Low);
        StatusLeds { green: off(green.into()), red: off(red.into()), yellow: off(yellow.into()) }
    }

    /// Lights the LEDs `lit` names.
    pub fn set(&mut self, lit: Lit) {
        self.green.set_level(lit.green.into());
        self.red.set_level(lit.red.into());
        self.yellow.set_level(lit.yellow.into());
    }
}
