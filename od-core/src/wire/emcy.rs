//! The EMCY message (CiA 301 §7.2.7.3.1): error code, error register, five manufacturer bytes.

use super::{exactly_8, u16_le};

/// The "error reset / no error" code.
pub const NO_ERROR: u16 = 0x0000;

/// One EMCY message.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct EmcyMessage {
    /// Error code (bytes 0..1, LSB first).
    pub code: u16,
    /// The error register 1001h at the time (byte 2).
    pub register: u8,
    /// Manufacturer-specific error field (bytes 3..7; 00h in every SIKO manual).
    pub manufacturer: [u8; 5],
}

impl EmcyMessage {
    /// A message with code `code`, register `register` and the manufacturer field 00h.
    pub const fn new(code: u16, register: u8) -> EmcyMessage {
        EmcyMessage { code, register, manufacturer: [0; 5] }
    }

    /// Parses the data bytes; `None` for any length but 8.
    pub fn parse(data: &[u8]) -> Option<EmcyMessage> {
        let d = exactly_8(data)?;
        Some(EmcyMessage { code: u16_le(d, 0), register: d[2], manufacturer: [d[3], d[4], d[5], d[6], d[7]] })
    }

    /// The 8 data bytes.
    pub const fn emit(&self) -> [u8; 8] {
        let c = self.code.to_le_bytes();
        let m = self.manufacturer;
        [c[0], c[1], self.register, m[0], m[1], m[2], m[3], m[4]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn byte_by_byte() {
        assert_eq!(EmcyMessage::new(0xFF15, 0x81).emit(), [0x15, 0xFF, 0x81, 0, 0, 0, 0, 0]);
        assert_eq!(EmcyMessage::new(NO_ERROR, 0).emit(), [0; 8]);
        assert_eq!(
            EmcyMessage::parse(&[0x20, 0x81, 0x11, 1, 2, 3, 4, 5]),
            Some(EmcyMessage { code: 0x8120, register: 0x11, manufacturer: [1, 2, 3, 4, 5] })
        );
        assert_eq!(EmcyMessage::parse(&[0x20, 0x81, 0x11]), None);
        assert_eq!(EmcyMessage::parse(&[0; 9]), None);
    }

    proptest! {
        #[test]
        fn round_trip(code: u16, register: u8, manufacturer: [u8; 5]) {
            let m = EmcyMessage { code, register, manufacturer };
            prop_assert_eq!(EmcyMessage::parse(&m.emit()), Some(m));
        }
    }
}
