//! CRC-32 (IEEE 802.3 / zlib: reflected polynomial EDB88320h, initial value and final XOR
//! FFFFFFFFh) with a 16-entry nibble table: 64 bytes of flash, two table look-ups per byte.
//! A parameter image is under a kilobyte and is checked at boot and after each save, so the
//! byte-wide 1 KiB table or a crate would buy nothing measurable.

const TABLE: [u32; 16] = {
    let mut t = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

/// A CRC-32 being computed over data that arrives in pieces.
#[derive(Clone, Copy, Debug)]
pub struct Crc32(u32);

impl Default for Crc32 {
    fn default() -> Self {
        Crc32::new()
    }
}

impl Crc32 {
    /// Nothing digested yet.
    pub const fn new() -> Crc32 {
        Crc32(0xFFFF_FFFF)
    }

    /// Digests `bytes`.
    #[inline]
    pub fn update(&mut self, bytes: &[u8]) {
        *self = self.digest(bytes);
    }

    /// This CRC having digested `bytes`. (By value: the callers keep the state in a register.)
    #[must_use]
    #[inline(never)]
    pub const fn digest(self, bytes: &[u8]) -> Crc32 {
        // (A `while` loop: a `const fn`, so that a device's identity is computed at compile
        // time, [`super::identity`].)
        let mut c = self.0;
        let mut i = 0;
        while i < bytes.len() {
            c ^= bytes[i] as u32;
            c = (c >> 4) ^ TABLE[(c & 0xF) as usize];
            c = (c >> 4) ^ TABLE[(c & 0xF) as usize];
            i += 1;
        }
        Crc32(c)
    }

    /// The checksum of everything digested.
    pub const fn finish(self) -> u32 {
        !self.0
    }
}

/// The CRC-32 of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(bytes);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_values() {
        // The catalogue check value of CRC-32/ISO-HDLC, and two more fixed points.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(&[0]), 0xD202_EF8D);
    }

    #[test]
    fn pieces_equal_whole() {
        let data: [u8; 37] = core::array::from_fn(|i| (i * 37 + 11) as u8);
        let mut c = Crc32::new();
        c.update(&data[..5]);
        c.update(&data[5..20]);
        c.update(&data[20..]);
        assert_eq!(c.finish(), crc32(&data));
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        let data = *b"SIKO parameter image";
        let good = crc32(&data);
        for i in 0..data.len() * 8 {
            let mut d = data;
            d[i / 8] ^= 1 << (i % 8);
            assert_ne!(crc32(&d), good, "bit {i}");
        }
    }
}
