//! The two bi-colour LEDs and the backlight.
//!
//! Each of the four LED elements (5F12h sub 2-5) either follows its set point ("acknowledgement
//! dependent", value 1, the factory setting: left = set point 1, right = set point 2; off when
//! invalid, red unacknowledged, green acknowledged; manual Table 1) or, with value 0, its
//! control-word bit (11 LED1 green left, 14 LED2 red left, 12 LED3 green right, 13 LED4 red
//! right; manual 3.3, AP10T A8). An element blinks when it is under control-word control and
//! control-word bit 15 is set, or when 5F12h sub 6 "FLASH LED" is 1 (D-AP-6). The backlight's
//! white and red parts are independent (5F12h sub 7, 8; AP10T A9) and blink together with
//! sub 9.

use crate::time::Instant;

use super::screen::{blink_on, next_blink_edge};
use super::setpoint::SetPoints;
use super::words::cw;

/// One bi-colour LED.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Bicolour {
    /// The green element is lit.
    pub green: bool,
    /// The red element is lit.
    pub red: bool,
}

/// Both LEDs at one instant.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Leds {
    /// Left LED (LED1 green, LED2 red).
    pub left: Bicolour,
    /// Right LED (LED3 green, LED4 red).
    pub right: Bicolour,
}

/// The backlight at one instant.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Backlight {
    /// The white backlight is lit.
    pub white: bool,
    /// The red backlight is lit.
    pub red: bool,
}

/// The LED and backlight settings of 5F12h sub 2-9.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LightConfig {
    /// Sub 2-5: acknowledgement-dependent (true, factory) or control-word driven, in the order
    /// LED1 green left, LED2 red left, LED3 green right, LED4 red right.
    pub ack_dependent: [bool; 4],
    /// Sub 6: FLASH LED.
    pub flash_leds: bool,
    /// Sub 7: backlight white.
    pub backlight_white: bool,
    /// Sub 8: backlight red.
    pub backlight_red: bool,
    /// Sub 9: FLASH backlight.
    pub flash_backlight: bool,
}

impl LightConfig {
    /// The factory settings.
    pub const FACTORY: LightConfig = LightConfig {
        ack_dependent: [true; 4],
        flash_leds: false,
        backlight_white: true,
        backlight_red: true,
        flash_backlight: false,
    };
}

impl Default for LightConfig {
    fn default() -> Self {
        LightConfig::FACTORY
    }
}

/// The four elements in 5F12h order as bits 0-3 (LED1 green left, LED2 red left, LED3 green
/// right, LED4 red right): which are on, and which of those blink.
fn elements(cfg: &LightConfig, sps: &SetPoints) -> (u8, u8) {
    let w = sps.control;
    // A valid set point lights its green element (bit 2i) acknowledged, else its red one.
    let mut by_ack = 0u8;
    for (i, s) in sps.sp.iter().enumerate() {
        if s.valid {
            by_ack |= (if s.acknowledged { 1 } else { 2 }) << (2 * i);
        }
    }
    // Control word bits 11 (LED1), 14 (LED2), 12 (LED3), 13 (LED4) to elements 0..=3.
    let by_cw = (w >> 11 & 1 | w >> 13 & 2 | w >> 10 & 0b1100) as u8;
    let ack_dependent = cfg.ack_dependent.iter().rev().fold(0u8, |m, &on| m << 1 | on as u8);
    let on = (by_ack & ack_dependent) | (by_cw & !ack_dependent);
    // FLASH LED makes every element blink, control word bit 15 those under its control.
    let blinks = if cfg.flash_leds {
        0x0F
    } else if w & cw::LED_BLINK != 0 {
        !ack_dependent
    } else {
        0
    };
    (on, on & blinks)
}

/// The LEDs at `now`.
pub fn leds(cfg: &LightConfig, sps: &SetPoints, now: Instant) -> Leds {
    Leds::from_bits(lit(cfg, sps, now))
}

/// The elements lit at `now`, bit `i` = LED element `i` + 1 (LED1 green left, LED2 red left,
/// LED3 green right, LED4 red right).
pub(crate) fn lit(cfg: &LightConfig, sps: &SetPoints, now: Instant) -> u8 {
    let (on, blinking) = elements(cfg, sps);
    if blink_on(now) {
        on
    } else {
        on & !blinking
    }
}

impl Leds {
    /// The LEDs with the elements of `lit` on (bit `i` = LED element `i` + 1).
    pub(crate) fn from_bits(lit: u8) -> Leds {
        let e = |i: u8| lit & 1 << i != 0;
        Leds { left: Bicolour { green: e(0), red: e(1) }, right: Bicolour { green: e(2), red: e(3) } }
    }

    /// The elements lit, bit `i` = LED element `i` + 1 (LED1 green left, LED2 red left, LED3
    /// green right, LED4 red right), as the view computed them.
    pub fn bits(&self) -> u8 {
        let (l, r) = (self.left, self.right);
        l.green as u8 | (l.red as u8) << 1 | (r.green as u8) << 2 | (r.red as u8) << 3
    }
}

/// The backlight at `now`.
pub fn backlight(cfg: &LightConfig, now: Instant) -> Backlight {
    let on = !cfg.flash_backlight || blink_on(now);
    Backlight { white: cfg.backlight_white && on, red: cfg.backlight_red && on }
}

/// When the LEDs or the backlight next change by themselves after `now` (`None`: not before an
/// input changes).
pub fn next_change(cfg: &LightConfig, sps: &SetPoints, now: Instant) -> Option<Instant> {
    blinks(cfg, sps).then(|| next_blink_edge(now))
}

/// Whether a lit LED element or the lit backlight blinks (changes with the blink clock).
pub(crate) fn blinks(cfg: &LightConfig, sps: &SetPoints) -> bool {
    let led_blinks = elements(cfg, sps).1 != 0;
    let light_blinks = cfg.flash_backlight && (cfg.backlight_white || cfg.backlight_red);
    led_blinks || light_blinks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::ap10t::setpoint::Which;

    const LIT: Instant = Instant::from_millis(250);
    const DARK: Instant = Instant::from_millis(750);
    const OFF: Bicolour = Bicolour { green: false, red: false };
    const RED: Bicolour = Bicolour { green: false, red: true };
    const GREEN: Bicolour = Bicolour { green: true, red: false };

    fn rpdo(s: &mut SetPoints, which: Which, cw: u16) {
        let [lo, hi] = cw.to_le_bytes();
        s.receive(which, &[1, 0, 0, 0, 0, 0, lo, hi]);
    }

    #[test]
    fn table_1_factory_behaviour() {
        let cfg = LightConfig::FACTORY;
        let mut s = SetPoints::new();
        assert_eq!(leds(&cfg, &s, LIT), Leds { left: OFF, right: OFF });
        rpdo(&mut s, Which::Sp1, 0x0004);
        assert_eq!(leds(&cfg, &s, LIT), Leds { left: RED, right: OFF });
        assert_eq!(leds(&cfg, &s, DARK), Leds { left: RED, right: OFF }, "steady, no blinking");
        rpdo(&mut s, Which::Sp2, 0x0204);
        assert_eq!(leds(&cfg, &s, LIT), Leds { left: RED, right: RED });
        s.acknowledge();
        assert_eq!(leds(&cfg, &s, LIT), Leds { left: GREEN, right: GREEN });
        rpdo(&mut s, Which::Sp2, 0x0004);
        assert_eq!(leds(&cfg, &s, LIT), Leds { left: GREEN, right: OFF });
        assert_eq!(next_change(&cfg, &s, LIT), None);
        // Control-word LED bits do nothing while every element is acknowledgement-dependent.
        rpdo(&mut s, Which::Sp1, 0xF804);
        assert_eq!(leds(&cfg, &s, DARK), Leds { left: GREEN, right: OFF });
    }

    #[test]
    fn d27c_control_word_drives_elements_set_to_0() {
        let mut cfg = LightConfig::FACTORY;
        cfg.ack_dependent[1] = false; // 5F12h sub 3 := 0: LED2 red left
        let mut s = SetPoints::new();
        rpdo(&mut s, Which::Sp1, 0x0004); // SP1 valid, unacknowledged
        assert_eq!(leds(&cfg, &s, LIT).left, OFF, "red left no longer follows the set point");
        rpdo(&mut s, Which::Sp1, 0x4004); // CW bit 14
        assert_eq!(leds(&cfg, &s, LIT).left, RED);
        assert_eq!(leds(&cfg, &s, DARK).left, RED);
        rpdo(&mut s, Which::Sp1, 0xC004); // + bit 15: blinks
        assert_eq!(leds(&cfg, &s, LIT).left, RED);
        assert_eq!(leds(&cfg, &s, DARK).left, OFF);
        assert_eq!(next_change(&cfg, &s, LIT), Some(Instant::from_millis(500)));
        // Green left still follows set point 1 and does not blink by bit 15.
        s.acknowledge();
        assert_eq!(leds(&cfg, &s, DARK).left, GREEN);
    }

    #[test]
    fn every_element_by_its_control_word_bit() {
        let cfg = LightConfig { ack_dependent: [false; 4], ..LightConfig::FACTORY };
        let mut s = SetPoints::new();
        for (cw, want) in [
            (1u16 << 11, Leds { left: GREEN, right: OFF }),
            (1 << 14, Leds { left: RED, right: OFF }),
            (1 << 12, Leds { left: OFF, right: GREEN }),
            (1 << 13, Leds { left: OFF, right: RED }),
            (0, Leds { left: OFF, right: OFF }),
        ] {
            rpdo(&mut s, Which::Sp2, cw);
            assert_eq!(leds(&cfg, &s, DARK), want, "{cw:04X}");
        }
    }

    #[test]
    fn flash_led_makes_every_lit_element_blink() {
        let cfg = LightConfig { flash_leds: true, ..LightConfig::FACTORY };
        let mut s = SetPoints::new();
        rpdo(&mut s, Which::Sp1, 0x0004);
        assert_eq!(leds(&cfg, &s, LIT).left, RED);
        assert_eq!(leds(&cfg, &s, DARK).left, OFF);
        assert!(next_change(&cfg, &s, LIT).is_some());
    }

    #[test]
    fn bits_round_trip() {
        for lit in 0..16 {
            assert_eq!(Leds::from_bits(lit).bits(), lit);
        }
        assert_eq!(Leds { left: RED, right: GREEN }.bits(), 0b0110);
    }

    #[test]
    fn backlight_colours_and_flashing() {
        let cfg = LightConfig::FACTORY;
        assert_eq!(backlight(&cfg, DARK), Backlight { white: true, red: true });
        let white = LightConfig { backlight_red: false, ..cfg };
        assert_eq!(backlight(&white, DARK), Backlight { white: true, red: false });
        let flash = LightConfig { flash_backlight: true, backlight_white: false, ..cfg };
        assert_eq!(backlight(&flash, LIT), Backlight { white: false, red: true });
        assert_eq!(backlight(&flash, DARK), Backlight { white: false, red: false });
        assert_eq!(next_change(&flash, &SetPoints::new(), DARK), Some(Instant::from_millis(1000)));
        let dark = LightConfig { backlight_white: false, backlight_red: false, flash_backlight: true, ..cfg };
        assert_eq!(next_change(&dark, &SetPoints::new(), DARK), None);
    }
}
