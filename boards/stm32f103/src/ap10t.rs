//! The AP10T display board: the common MCU part, a segment-LCD driver chip on SPI2 for the two
//! rows of six digits, two bi-colour LEDs and four keys. No straps, no sensor.
//!
//! The board gives the device raw access: bytes to the LCD driver ([`Lcd::write`]), the key
//! levels ([`Keys::pressed`]) and the LED pins ([`Leds::set`]); what the rows show, the key
//! debouncing and the LED colours are the pure parts in `board_plan` and, with the device, in
//! the core.

use embassy_stm32::gpio::{AnyPin, Input, Level, Output, Pull, Speed};
use embassy_stm32::mode::Blocking;
use embassy_stm32::peripherals::{PB12, PB13, PB14, PB15, SPI2};
use embassy_stm32::spi::{self, Spi, MODE_0};
use embassy_stm32::time::Hertz;
use embassy_stm32::Peri;

use crate::mcu::{self, Mcu};

/// SPI clock of the LCD driver: APB1 36 MHz / 64, well within any segment driver's limit.
pub const LCD_SPI_HZ: u32 = 562_500;

/// The LCD driver on SPI2 (NSS PB12, SCK PB13, MISO PB14, MOSI PB15).
pub struct Lcd {
    spi: Spi<'static, Blocking, spi::mode::Master>,
    nss: Output<'static>,
}

impl Lcd {
    /// The driver, deselected.
    pub fn new(
        spi: Peri<'static, SPI2>,
        nss: Peri<'static, PB12>,
        sck: Peri<'static, PB13>,
        miso: Peri<'static, PB14>,
        mosi: Peri<'static, PB15>,
    ) -> Lcd {
        let mut config = spi::Config::default();
        config.mode = MODE_0;
        config.frequency = Hertz(LCD_SPI_HZ);
        Lcd { spi: Spi::new_blocking(spi, sck, mosi, miso, config), nss: Output::new(nss, Level::High, Speed::Low) }
    }

    /// Sends one transaction (a command sequence or the display RAM image) with NSS low.
    pub fn write(&mut self, bytes: &[u8]) -> Result<(), spi::Error> {
        self.nss.set_low();
        let result = self.spi.blocking_write(bytes);
        self.nss.set_high();
        result
    }
}

/// The four keys (PA0..PA3, pull-ups, a pressed key reads low).
pub struct Keys {
    pins: [Input<'static>; 4],
}

impl Keys {
    /// The keys.
    pub fn new(pins: [Peri<'static, AnyPin>; 4]) -> Keys {
        Keys { pins: pins.map(|p| Input::new(p, Pull::Up)) }
    }

    /// The raw levels as pressed keys: bit `k` set = key `k + 1` reads low now (not debounced).
    pub fn pressed(&self) -> u8 {
        let mut bits = 0;
        for (k, pin) in self.pins.iter().enumerate() {
            if pin.is_low() {
                bits |= 1 << k;
            }
        }
        bits
    }
}

/// The two bi-colour LEDs: LED 1 green PB0 / red PB1, LED 2 green PB10 / red PB11, active high.
pub struct Leds {
    pins: [Output<'static>; 4],
}

impl Leds {
    /// The LEDs, off.
    pub fn new(pins: [Peri<'static, AnyPin>; 4]) -> Leds {
        Leds { pins: pins.map(|p| Output::new(p, Level::Low, Speed::Low)) }
    }

    /// Lights LED 1 (`second` false) or LED 2 green, red, both (orange) or none.
    pub fn set(&mut self, second: bool, green: bool, red: bool) {
        let base = if second { 2 } else { 0 };
        self.pins[base].set_level(green.into());
        self.pins[base + 1].set_level(red.into());
    }
}

/// The AP10T board.
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// The LCD driver.
    pub lcd: Lcd,
    /// The keys.
    pub keys: Keys,
    /// The LEDs.
    pub leds: Leds,
}

/// Initialises the MCU (clocks) and takes the board's peripherals.
pub fn take() -> Board {
    let p = embassy_stm32::init(mcu::config());
    Board {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        lcd: Lcd::new(p.SPI2, p.PB12, p.PB13, p.PB14, p.PB15),
        keys: Keys::new([p.PA0.into(), p.PA1.into(), p.PA2.into(), p.PA3.into()]),
        leds: Leds::new([p.PB0.into(), p.PB1.into(), p.PB10.into(), p.PB11.into()]),
    }
}
