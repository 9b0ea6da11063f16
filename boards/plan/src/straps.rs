//! The product variant a board is, from its strap pins, and its serial number from the MCU.
//!
//! Four straps (PB12..PB15, internal pull-ups, see `boards/README.md`) are read once at reset:
//! an open strap reads 1, a fitted one (0 Ω to ground) reads 0. [`Straps`] holds the levels as
//! read, bit `k` for strap `k`; each product decodes the straps it uses and ignores the rest.
//!
//! Only what leaves the object dictionary as it is comes from straps (SGH10/SGH10L, the channel
//! of a redundant encoder: their tables are one or two). The rotary encoders' model and turns
//! select one of eight dictionaries each; linking all eight would cost about 58 KiB of flash, so
//! those are build options of the firmware (cargo features), one image per part number.

use od_core::devices::{sgh10, sgh50};
use od_core::storage::crc::crc32;

/// The strap levels as read: bit `k` set = strap `k` open (pulled up).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Straps(pub u8);

impl Straps {
    /// Every strap open: the board as it comes off the line without variant straps.
    pub const OPEN: Straps = Straps(0x0F);

    /// Is strap `k` fitted (reads 0)?
    pub const fn fitted(self, k: u8) -> bool {
        self.0 & (1 << k) == 0
    }

    /// SGH10: strap 0 fitted = SGH10L.
    pub const fn sgh10(self) -> sgh10::Variant {
        if self.fitted(0) {
            sgh10::Variant::Sgh10L
        } else {
            sgh10::Variant::Sgh10
        }
    }

    /// SGH50: strap 0 fitted = the redundant version, whose strap 1 fitted = the second
    /// channel; strap 1 means nothing on the single version.
    pub const fn sgh50(self) -> sgh50::Variant {
        if !self.fitted(0) {
            sgh50::Variant::Single
        } else if self.fitted(1) {
            sgh50::Variant::Redundant(sgh50::Channel::Second)
        } else {
            sgh50::Variant::Redundant(sgh50::Channel::First)
        }
    }

    /// WV58MR: strap 0 fitted = the redundant version, whose strap 1 fitted = the second
    /// channel. Returns (redundant, second channel).
    pub const fn wv58mr(self) -> (bool, bool) {
        let redundant = self.fitted(0);
        (redundant, redundant && self.fitted(1))
    }
}

/// The serial number (1018h sub 4) of a board whose flash holds none: the CRC-32 of the MCU's
/// 96-bit unique device ID (RM0008 §30.2), so that two blank boards on one bus still differ in
/// their LSS address and LSS fastscan can tell them apart. The production line replaces it with
/// the product's real serial number (factory data in the parameter image).
pub fn serial_from_uid(uid: &[u8; 12]) -> u32 {
    crc32(uid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_straps_are_the_default_products() {
        assert_eq!(Straps::OPEN.sgh10(), sgh10::Variant::Sgh10);
        assert_eq!(Straps::OPEN.sgh50(), sgh50::Variant::Single);
        assert_eq!(Straps::OPEN.wv58mr(), (false, false));
        // Straps beyond the four never matter.
        assert_eq!(Straps(0xFF).sgh50(), sgh50::Variant::Single);
    }

    #[test]
    fn every_variant_has_its_straps() {
        assert_eq!(Straps(0b1110).sgh10(), sgh10::Variant::Sgh10L);
        assert_eq!(Straps(0b1110).sgh50(), sgh50::Variant::Redundant(sgh50::Channel::First));
        assert_eq!(Straps(0b1100).sgh50(), sgh50::Variant::Redundant(sgh50::Channel::Second));
        assert_eq!(Straps(0b1101).sgh50(), sgh50::Variant::Single, "channel strap alone");
        assert_eq!(Straps(0b1100).wv58mr(), (true, true));
        assert_eq!(Straps(0b1110).wv58mr(), (true, false));
        assert_eq!(Straps(0b1101).wv58mr(), (false, false), "channel strap alone");
    }

    #[test]
    fn serial_is_the_crc_of_the_unique_id() {
        // CRC-32 (zlib) of the twelve bytes 00h..0Bh, computed independently.
        let uid: [u8; 12] = core::array::from_fn(|i| i as u8);
        assert_eq!(serial_from_uid(&uid), 0x9270_C965);
        let mut next = uid;
        next[11] += 1;
        assert_ne!(serial_from_uid(&next), serial_from_uid(&uid), "neighbouring dies differ");
    }
}
