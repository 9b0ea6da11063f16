//! The AP10T display board: the common MCU part, a Holtek HT1621 segment-LCD driver on SPI2
//! for the two rows of six 7-segment digits, two bi-colour LEDs and four keys. No straps, no
//! sensor.
//!
//! The device (`od_core::devices::ap10t::Ap10t`) decides what the rows show and what a key
//! does; the board shows a [`Screen`] ([`Lcd::show`]), reports debounced key changes
//! ([`Keys::scan`]) and lights the LEDs ([`Leds::set`]); [`Panel`] is the device's [`Io`]. The
//! protocol details, font and debouncing are in `board_plan::lcd` and `board_plan::keys`,
//! host-tested. The backlight has no switchable supply on this board: 5F12h sub 7-9 act on
//! the screen model only.

use board_plan::keys::{Change, Debouncer};
use board_plan::lcd::{frame, screen_frame, Screen, FRAME_LEN, INIT};
use embassy_stm32::pac::{self, spi::vals as spi_vals};
use embassy_stm32::peripherals::{PA0, PA1, PA2, PA3, PB0, PB1, PB10, PB11, PB12, PB13, PB15, SPI2};
use embassy_stm32::rcc::enable_and_reset_without_stop;
use embassy_stm32::Peri;

use od_core::devices::ap10t::{Ap10t, Key, View};
use od_core::node::Core;
use od_core::Instant;

use crate::mcu::{self, Mcu};
use crate::Io;

/// The HT1621's write clock: APB1 36 MHz / 256 = 140.6 kHz, under the driver's 150 kHz at 3 V.
/// A whole display (18 bytes) takes 1 ms.
pub const LCD_SPI_HZ: u32 = 140_625;

/// SPI_CR1.BR for [`LCD_SPI_HZ`]: the clock divided by 2 << 7 = 256.
const LCD_SPI_BR: u8 = 7;

/// The LCD driver on SPI2, transmit only: CS = NSS PB12, WR = SCK PB13, DATA = MOSI PB15 (the
/// driver's RD is not connected; PB14 stays free). The SPI's registers are written directly
/// (master, mode 0, 8 bits, most significant bit first, APB1 / 256, software NSS): the same
/// configuration and byte sequence as Embassy's blocking transmit-only driver, in a fraction of
/// its code.
pub struct Lcd(());

impl Lcd {
    /// The driver, deselected.
    pub fn new(
        _spi: Peri<'static, SPI2>,
        _nss: Peri<'static, PB12>,
        _sck: Peri<'static, PB13>,
        _mosi: Peri<'static, PB15>,
    ) -> Lcd {
        // NSS high (deselected) before PB12 becomes an output.
        pac::GPIOB.bsrr().write(|w| w.0 = 1 << 12);
        enable_and_reset_without_stop::<SPI2>();
        // PB12 (NSS) push-pull output at 2 MHz (MODE 10, CNF 00), PB13 (SCK) and PB15 (MOSI)
        // alternate function push-pull at 50 MHz (MODE 11, CNF 10).
        pac::GPIOB.cr(1).modify(|w| w.0 = w.0 & !0xF0FF_0000 | 0xB0B2_0000);
        pac::SPI2.cr1().write(|w| {
            w.set_mstr(spi_vals::Mstr::MASTER);
            w.set_br(spi_vals::Br::from_bits(LCD_SPI_BR));
            w.set_ssm(true);
            w.set_ssi(true);
            w.set_spe(true);
        });
        Lcd(())
    }

    /// Starts the driver (oscillator, bias, display on).
    pub fn init(&mut self) {
        self.write(&INIT)
    }

    /// Shows `screen` (writes the driver's whole display RAM).
    pub fn show(&mut self, screen: &Screen) {
        self.write(&frame(screen))
    }

    /// One transfer with CS low: each byte written when the transmit buffer is free, the
    /// transfer over when its echo has arrived (the F1's BSY flag clears too early).
    fn write(&mut self, bytes: &[u8]) {
        let spi = pac::SPI2;
        pac::GPIOB.brr().write(|w| w.0 = 1 << 12);
        for &b in bytes {
            let _ = crate::mcu::spi_exchange(spi, b);
        }
        pac::GPIOB.bsrr().write(|w| w.0 = 1 << 12);
    }
}

/// The four keys (PA0 front key, PA1 "←", PA2 "*", PA3 "↑"; pull-ups, a pressed key reads
/// low), debounced. The four pins are configured and read together through port A's registers.
pub struct Keys {
    debouncer: Debouncer,
}

impl Keys {
    /// The keys, all released: PA0..PA3 inputs with pull-up.
    pub fn new(_pins: (Peri<'static, PA0>, Peri<'static, PA1>, Peri<'static, PA2>, Peri<'static, PA3>)) -> Keys {
        // Input with pull-up or pull-down (MODE 00, CNF 10) for PA0..PA3 in CRL.
        pac::GPIOA.cr(0).modify(|w| w.0 = w.0 & !0xFFFF | 0x8888);
        // ODR = 1 selects the pull-up.
        pac::GPIOA.bsrr().write(|w| w.0 = 0xF);
        Keys { debouncer: Debouncer::new() }
    }

    /// Scans the keys at `now` (every sample period); returns the change of the debounced keys
    /// (bits as `board_plan::keys` orders them), if any.
    pub fn scan(&mut self, now: od_core::Instant) -> Option<Change> {
        self.debouncer.scan(Keys::raw(), now)
    }

    /// The raw levels as pressed keys: bit `k` set = key `k` (PA`k`) reads low now.
    fn raw() -> u8 {
        !pac::GPIOA.idr().read().0 as u8 & 0xF
    }
}

/// The two bi-colour LEDs: LED 1 green PB0 / red PB1, LED 2 green PB10 / red PB11, active high,
/// switched together through port B's set/reset register.
pub struct Leds(());

/// The LEDs' pins on port B (LED 1 green, red, LED 2 green, red) as a mask.
const LED_MASK: u32 = 1 << 0 | 1 << 1 | 1 << 10 | 1 << 11;

impl Leds {
    /// The LEDs, off: push-pull outputs, 2 MHz.
    pub fn new(_pins: (Peri<'static, PB0>, Peri<'static, PB1>, Peri<'static, PB10>, Peri<'static, PB11>)) -> Leds {
        let gpio = pac::GPIOB;
        gpio.brr().write(|w| w.0 = LED_MASK);
        // Push-pull output at 2 MHz (MODE 10, CNF 00): PB0, PB1 in CRL, PB10, PB11 in CRH.
        gpio.cr(0).modify(|w| w.0 = w.0 & !0xFF | 0x22);
        gpio.cr(1).modify(|w| w.0 = w.0 & !0xFF00 | 0x2200);
        Leds(())
    }

    /// Lights the elements of `lit` (bit 0 LED 1 green, 1 red, 2 LED 2 green, 3 red, as
    /// `Leds::bits` gives them) and darkens the others.
    pub fn set(&mut self, lit: u8) {
        let lit = lit as u32;
        // Bits 0, 1 are PB0, PB1; bits 2, 3 are PB10, PB11.
        let pins = lit & 0b11 | (lit & 0b1100) << 8;
        pac::GPIOB.bsrr().write(|w| w.0 = pins | (LED_MASK & !pins) << 16);
    }
}

/// How often the keys are scanned, in microseconds (the debouncer counts in these steps).
pub const KEY_SCAN_US: u32 = 1_000;

/// No frame: every frame starts with the write mode `101` (`board_plan::lcd::frame`), this
/// one with 1s, so the first view is always written.
const NOT_SHOWN: [u8; FRAME_LEN] = [0xFF; FRAME_LEN];

/// The front panel as the device's [`Io`]: key edges to the device, its view to the LCD (the
/// driver's RAM rewritten only when the frame for it changed) and the LEDs.
pub struct Panel {
    /// The LCD driver.
    pub lcd: Lcd,
    /// The keys.
    pub keys: Keys,
    /// The LEDs.
    pub leds: Leds,
    /// The frame the LCD driver last took ([`NOT_SHOWN`] before the first).
    shown: [u8; FRAME_LEN],
}

impl Panel {
    /// The panel, the LCD started.
    pub fn new(mut lcd: Lcd, keys: Keys, leds: Leds) -> Panel {
        lcd.init();
        Panel { lcd, keys, leds, shown: NOT_SHOWN }
    }
}

impl Io<Ap10t> for Panel {
    fn period_us(&self, _device: &Ap10t) -> u32 {
        KEY_SCAN_US
    }

    fn sample(&mut self, device: &mut Ap10t, core: &mut Core, now: Instant) {
        let Some(change) = self.keys.scan(now) else { return };
        for (k, key) in Key::ALL.into_iter().enumerate() {
            if change.released & (1 << k) != 0 {
                device.release(core, key, now);
            }
            if change.pressed & (1 << k) != 0 {
                device.press(core, key, now);
            }
        }
    }

    fn show(&mut self, device: &Ap10t, _core: &Core, now: Instant) -> Option<Instant> {
        let View { screen, leds, .. } = device.view(now);
        // Comparing the 18 bytes for the driver is less code than comparing views.
        let bytes = screen_frame(&screen);
        if self.shown != bytes {
            self.lcd.write(&bytes);
            self.shown = bytes;
        }
        self.leds.set(leds.bits());
        device.next_change(now)
    }
}

/// The AP10T board.
pub struct Board {
    /// The shared peripherals.
    pub mcu: Mcu,
    /// LCD, keys and LEDs.
    pub io: Panel,
}

/// Initialises the MCU (clocks) and takes the board's peripherals.
pub fn take() -> Board {
    let p = embassy_stm32::init(mcu::config());
    Board {
        mcu: Mcu::new(p.CAN, p.PA11, p.PA12, p.PB5, p.FLASH, p.IWDG),
        io: Panel::new(
            Lcd::new(p.SPI2, p.PB12, p.PB13, p.PB15),
            Keys::new((p.PA0, p.PA1, p.PA2, p.PA3)),
            Leds::new((p.PB0, p.PB1, p.PB10, p.PB11)),
        ),
    }
}
