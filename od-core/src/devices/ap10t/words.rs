//! The control word 5F0Ch (bytes 6-7 of both RPDOs) and the status word 5F19h (bytes 6-7 of
//! both TPDOs) as typed values, bit layouts as the manual's Tables 10 and 11 print them.
//!
//! The two words put the same facts at different bits (acknowledgement of set point 1: control
//! bit 10, status bit 5; of set point 2: 6 and 3; validity of set point 2: 9 and 10; data
//! identifier: 7 and 9). That is the manual, not a slip (digest §3.5.3).

/// Bit masks of the control word 5F0Ch (manual Table 10).
pub mod cw {
    /// Validity of set point 1 (1 = valid).
    pub const SP1_VALID: u16 = 1 << 2;
    /// Display range (1 = extended, down to -999999).
    pub const EXTENDED_RANGE: u16 = 1 << 3;
    /// Acknowledgement of set point 2.
    pub const SP2_ACK: u16 = 1 << 6;
    /// Data identifier (0 = number, 1 = ASCII) of the set point in the same RPDO.
    pub const ASCII: u16 = 1 << 7;
    /// Guarding bit, mirrored into status word bit 8.
    pub const GUARDING: u16 = 1 << 8;
    /// Validity of set point 2.
    pub const SP2_VALID: u16 = 1 << 9;
    /// Acknowledgement of set point 1.
    pub const SP1_ACK: u16 = 1 << 10;
    /// LED1 green left.
    pub const LED1_GREEN_LEFT: u16 = 1 << 11;
    /// LED3 green right.
    pub const LED3_GREEN_RIGHT: u16 = 1 << 12;
    /// LED4 red right.
    pub const LED4_RED_RIGHT: u16 = 1 << 13;
    /// LED2 red left.
    pub const LED2_RED_LEFT: u16 = 1 << 14;
    /// LED blinking.
    pub const LED_BLINK: u16 = 1 << 15;
    /// The reserved bits 0, 1, 4 and 5 ("always 0").
    pub const RESERVED: u16 = (1 << 0) | (1 << 1) | (1 << 4) | (1 << 5);
}

/// Bit masks of the status word 5F19h (manual Table 11).
pub mod sw {
    /// Front key actuated.
    pub const FRONT_KEY: u16 = 1 << 0;
    /// Validity of set point 1.
    pub const SP1_VALID: u16 = 1 << 2;
    /// Acknowledgement of set point 2.
    pub const SP2_ACK: u16 = 1 << 3;
    /// Acknowledgement of set point 1.
    pub const SP1_ACK: u16 = 1 << 5;
    /// Guarding bit, mirrored from control word bit 8.
    pub const GUARDING: u16 = 1 << 8;
    /// Data identifier (1 = ASCII), only in answers to a remote request, otherwise 0.
    pub const ASCII: u16 = 1 << 9;
    /// Validity of set point 2.
    pub const SP2_VALID: u16 = 1 << 10;
    /// "←" key actuated.
    pub const LEFT_KEY: u16 = 1 << 13;
    /// "*" key actuated.
    pub const STAR_KEY: u16 = 1 << 14;
    /// "↑" key actuated.
    pub const UP_KEY: u16 = 1 << 15;
}

const fn bit(word: u16, mask: u16) -> bool {
    word & mask != 0
}

const fn put(flag: bool, mask: u16) -> u16 {
    if flag {
        mask
    } else {
        0
    }
}

/// The control word 5F0Ch, as a master sends it in bytes 6-7 of RPDO1 and RPDO2.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct ControlWord {
    /// Bit 2: set point 1 is valid.
    pub sp1_valid: bool,
    /// Bit 3: extended display range.
    pub extended_range: bool,
    /// Bit 6: set point 2 acknowledged by the master.
    pub sp2_ack: bool,
    /// Bit 7: the set point in this RPDO is ASCII text (0: a number).
    pub ascii: bool,
    /// Bit 8: the guarding bit.
    pub guarding: bool,
    /// Bit 9: set point 2 is valid.
    pub sp2_valid: bool,
    /// Bit 10: set point 1 acknowledged by the master.
    pub sp1_ack: bool,
    /// Bit 11: LED1 green left on (when 5F12h sub 2 = 0).
    pub led1_green_left: bool,
    /// Bit 12: LED3 green right on (when 5F12h sub 4 = 0).
    pub led3_green_right: bool,
    /// Bit 13: LED4 red right on (when 5F12h sub 5 = 0).
    pub led4_red_right: bool,
    /// Bit 14: LED2 red left on (when 5F12h sub 3 = 0).
    pub led2_red_left: bool,
    /// Bit 15: the LEDs under control-word control blink.
    pub led_blink: bool,
    /// The reserved bits (0, 1, 4, 5) as received; they have no effect and are kept only so
    /// that 5F0Ch reads back what was received.
    pub reserved: u16,
}

impl ControlWord {
    /// Decodes the 16-bit word.
    pub const fn from_bits(w: u16) -> ControlWord {
        ControlWord {
            sp1_valid: bit(w, cw::SP1_VALID),
            extended_range: bit(w, cw::EXTENDED_RANGE),
            sp2_ack: bit(w, cw::SP2_ACK),
            ascii: bit(w, cw::ASCII),
            guarding: bit(w, cw::GUARDING),
            sp2_valid: bit(w, cw::SP2_VALID),
            sp1_ack: bit(w, cw::SP1_ACK),
            led1_green_left: bit(w, cw::LED1_GREEN_LEFT),
            led3_green_right: bit(w, cw::LED3_GREEN_RIGHT),
            led4_red_right: bit(w, cw::LED4_RED_RIGHT),
            led2_red_left: bit(w, cw::LED2_RED_LEFT),
            led_blink: bit(w, cw::LED_BLINK),
            reserved: w & cw::RESERVED,
        }
    }

    /// The 16-bit word (`from_bits(w).bits() == w` for every `w`).
    pub const fn bits(&self) -> u16 {
        put(self.sp1_valid, cw::SP1_VALID)
            | put(self.extended_range, cw::EXTENDED_RANGE)
            | put(self.sp2_ack, cw::SP2_ACK)
            | put(self.ascii, cw::ASCII)
            | put(self.guarding, cw::GUARDING)
            | put(self.sp2_valid, cw::SP2_VALID)
            | put(self.sp1_ack, cw::SP1_ACK)
            | put(self.led1_green_left, cw::LED1_GREEN_LEFT)
            | put(self.led3_green_right, cw::LED3_GREEN_RIGHT)
            | put(self.led4_red_right, cw::LED4_RED_RIGHT)
            | put(self.led2_red_left, cw::LED2_RED_LEFT)
            | put(self.led_blink, cw::LED_BLINK)
            | (self.reserved & cw::RESERVED)
    }

    /// Decodes bytes 6-7 of an RPDO (byte 6 the low byte).
    pub const fn from_le_bytes(b: [u8; 2]) -> ControlWord {
        ControlWord::from_bits(u16::from_le_bytes(b))
    }

    /// The word as bytes 6-7 of an RPDO.
    pub const fn to_le_bytes(&self) -> [u8; 2] {
        self.bits().to_le_bytes()
    }
}

/// The status word 5F19h, as the AP10T sends it in bytes 6-7 of TPDO1 and TPDO2.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct StatusWord {
    /// Bit 0: the front key is actuated.
    pub front_key: bool,
    /// Bit 2: set point 1 is valid.
    pub sp1_valid: bool,
    /// Bit 3: set point 2 is acknowledged.
    pub sp2_ack: bool,
    /// Bit 5: set point 1 is acknowledged.
    pub sp1_ack: bool,
    /// Bit 8: the guarding bit of the last control word.
    pub guarding: bool,
    /// Bit 9: the set point in this frame is ASCII text (answers to a remote request only).
    pub ascii: bool,
    /// Bit 10: set point 2 is valid.
    pub sp2_valid: bool,
    /// Bit 13: the "←" key is actuated.
    pub left_key: bool,
    /// Bit 14: the "*" key is actuated.
    pub star_key: bool,
    /// Bit 15: the "↑" key is actuated.
    pub up_key: bool,
}

impl StatusWord {
    /// Decodes the 16-bit word; the reserved bits (1, 4, 6, 7, 11, 12) are ignored.
    pub const fn from_bits(w: u16) -> StatusWord {
        StatusWord {
            front_key: bit(w, sw::FRONT_KEY),
            sp1_valid: bit(w, sw::SP1_VALID),
            sp2_ack: bit(w, sw::SP2_ACK),
            sp1_ack: bit(w, sw::SP1_ACK),
            guarding: bit(w, sw::GUARDING),
            ascii: bit(w, sw::ASCII),
            sp2_valid: bit(w, sw::SP2_VALID),
            left_key: bit(w, sw::LEFT_KEY),
            star_key: bit(w, sw::STAR_KEY),
            up_key: bit(w, sw::UP_KEY),
        }
    }

    /// The 16-bit word, reserved bits 0.
    pub const fn bits(&self) -> u16 {
        put(self.front_key, sw::FRONT_KEY)
            | put(self.sp1_valid, sw::SP1_VALID)
            | put(self.sp2_ack, sw::SP2_ACK)
            | put(self.sp1_ack, sw::SP1_ACK)
            | put(self.guarding, sw::GUARDING)
            | put(self.ascii, sw::ASCII)
            | put(self.sp2_valid, sw::SP2_VALID)
            | put(self.left_key, sw::LEFT_KEY)
            | put(self.star_key, sw::STAR_KEY)
            | put(self.up_key, sw::UP_KEY)
    }

    /// The word as bytes 6-7 of a TPDO (byte 6 the low byte).
    pub const fn to_le_bytes(&self) -> [u8; 2] {
        self.bits().to_le_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_word_bits_as_table_10() {
        // Each named bit alone decodes to exactly its field.
        let one = |w: u16| ControlWord::from_bits(w);
        assert!(one(1 << 2).sp1_valid);
        assert!(one(1 << 3).extended_range);
        assert!(one(1 << 6).sp2_ack);
        assert!(one(1 << 7).ascii);
        assert!(one(1 << 8).guarding);
        assert!(one(1 << 9).sp2_valid);
        assert!(one(1 << 10).sp1_ack);
        assert!(one(1 << 11).led1_green_left);
        assert!(one(1 << 12).led3_green_right);
        assert!(one(1 << 13).led4_red_right);
        assert!(one(1 << 14).led2_red_left);
        assert!(one(1 << 15).led_blink);
        assert_eq!(one(1 << 2), ControlWord { sp1_valid: true, ..ControlWord::default() });
        for b in [0, 1, 4, 5] {
            assert_eq!(one(1 << b), ControlWord { reserved: 1 << b, ..ControlWord::default() });
        }
    }

    #[test]
    fn control_word_round_trips_every_value() {
        for w in 0..=u16::MAX {
            assert_eq!(ControlWord::from_bits(w).bits(), w);
        }
    }

    #[test]
    fn control_words_of_the_digest_vectors() {
        // D23: bytes 6-7 "04 05" = 0504h: SP1 valid, guarding bit, SP1 acknowledged.
        let d23 = ControlWord::from_le_bytes([0x04, 0x05]);
        assert_eq!(d23, ControlWord { sp1_valid: true, guarding: true, sp1_ack: true, ..ControlWord::default() });
        // D24: "84 00": ASCII + SP1 valid.
        let d24 = ControlWord::from_le_bytes([0x84, 0x00]);
        assert!(d24.ascii && d24.sp1_valid && d24.bits() == 0x0084);
        // D27: "4C 02" = 024Ch: SP1 valid, extended, SP2 acknowledged, SP2 valid.
        let d27 =
            ControlWord { sp1_valid: true, extended_range: true, sp2_ack: true, sp2_valid: true, ..Default::default() };
        assert_eq!(d27.to_le_bytes(), [0x4C, 0x02]);
        // D27c: C004h = LED2 red left + blinking + SP1 valid.
        let d27c = ControlWord { sp1_valid: true, led2_red_left: true, led_blink: true, ..Default::default() };
        assert_eq!(d27c.to_le_bytes(), [0x04, 0xC0]);
    }

    #[test]
    fn status_word_bits_as_table_11() {
        let all = StatusWord {
            front_key: true,
            sp1_valid: true,
            sp2_ack: true,
            sp1_ack: true,
            guarding: true,
            ascii: true,
            sp2_valid: true,
            left_key: true,
            star_key: true,
            up_key: true,
        };
        // Every bit but the reserved 1, 4, 6, 7, 11, 12.
        assert_eq!(all.bits(), 0b1110_0111_0010_1101);
        assert_eq!(StatusWord::from_bits(0xFFFF), all);
        assert_eq!(StatusWord::from_bits(0xFFFF).bits(), 0xE72D);
        // D22: front key held with SP1 valid and acknowledged = 0025h; D23: 0124h.
        let d22 = StatusWord { front_key: true, sp1_valid: true, sp1_ack: true, ..Default::default() };
        assert_eq!(d22.to_le_bytes(), [0x25, 0x00]);
        let d23 = StatusWord { sp1_valid: true, sp1_ack: true, guarding: true, ..Default::default() };
        assert_eq!(d23.bits(), 0x0124);
        for (field, b) in [
            (StatusWord { sp2_ack: true, ..Default::default() }, 3),
            (StatusWord { ascii: true, ..Default::default() }, 9),
            (StatusWord { sp2_valid: true, ..Default::default() }, 10),
            (StatusWord { left_key: true, ..Default::default() }, 13),
            (StatusWord { star_key: true, ..Default::default() }, 14),
            (StatusWord { up_key: true, ..Default::default() }, 15),
        ] {
            assert_eq!(field.bits(), 1 << b);
            assert_eq!(StatusWord::from_bits(1 << b), field);
        }
    }
}
