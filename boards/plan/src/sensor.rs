//! The boards' position sensor: an absolute magnetic angle sensor with a multiturn counter,
//! read over SPI, and the raw counts the devices take from it.
//!
//! The sensor front-end answers every read with a 5-byte frame, most significant byte first:
//!
//! | bytes | content |
//! |---|---|
//! | 0..=1 | turn counter, 16 bits (revolutions of the shaft or the wire drum) |
//! | 2..=3 | bits 15..2: angle, 14 bits (16384 steps per turn); bit 1: error; bit 0: warning |
//! | 4 | CRC-8 (polynomial 1Dh, initial value FFh, final XOR FFh) over bytes 0..=3 |
//!
//! A frame of all 00h or all FFh is no sensor at all (MISO stuck), a CRC mismatch or the error
//! bit is the sensor's own diagnosis (magnet lost, field out of range). The warning bit (field
//! weak but still valid) does not invalidate the reading.

use od_core::encoder::SensorFault;

/// Bytes in one sensor frame.
pub const FRAME_LEN: usize = 5;

/// Angle steps per turn (14 bits).
pub const STEPS_PER_TURN: u32 = 16384;

/// One valid reading.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Reading {
    /// Turn counter.
    pub turns: u16,
    /// Angle within the turn, 0..16384.
    pub angle: u16,
    /// The sensor warned (weak field) but the reading is valid.
    pub warning: bool,
}

/// CRC-8, polynomial 1Dh (SAE J1850), initial value FFh, final XOR FFh.
pub const fn crc8(data: &[u8]) -> u8 {
    let mut crc = 0xFFu8;
    let mut i = 0;
    while i < data.len() {
        crc ^= data[i];
        let mut b = 0;
        while b < 8 {
            crc = if crc & 0x80 != 0 { (crc << 1) ^ 0x1D } else { crc << 1 };
            b += 1;
        }
        i += 1;
    }
    crc ^ 0xFF
}

/// Decodes one frame.
pub fn decode(frame: &[u8; FRAME_LEN]) -> Result<Reading, SensorFault> {
    if frame.iter().all(|&b| b == 0x00) || frame.iter().all(|&b| b == 0xFF) {
        return Err(SensorFault::NoResponse);
    }
    if crc8(&frame[..4]) != frame[4] {
        return Err(SensorFault::Diagnosis);
    }
    let word = u16::from_be_bytes([frame[2], frame[3]]);
    if word & 0b10 != 0 {
        return Err(SensorFault::Diagnosis);
    }
    Ok(Reading { turns: u16::from_be_bytes([frame[0], frame[1]]), angle: word >> 2, warning: word & 1 != 0 })
}

/// Encodes a frame as the sensor sends it (for simulations and tests).
pub fn encode(turns: u16, angle: u16, error: bool, warning: bool) -> [u8; FRAME_LEN] {
    let word = ((angle & 0x3FFF) << 2) | ((error as u16) << 1) | warning as u16;
    let t = turns.to_be_bytes();
    let w = word.to_be_bytes();
    let mut f = [t[0], t[1], w[0], w[1], 0];
    f[4] = crc8(&f[..4]);
    f
}

/// The raw count of a multiturn rotary encoder (600Ch of the WV5800M): `turns` modulo the
/// `turn_bits`-bit counter (0 for a singleturn encoder) times 16384 plus the angle.
pub const fn multiturn_raw(r: Reading, turn_bits: u32) -> u32 {
    let turns = if turn_bits == 0 { 0 } else { r.turns as u32 & ((1u32 << turn_bits) - 1) };
    turns * STEPS_PER_TURN + r.angle as u32
}

/// The raw value of a wire encoder: the pulled-out wire length in micrometres, from the drum's
/// turns and angle at `um_per_turn` micrometres of wire per drum turn (turn 0, angle 0 = wire
/// fully retracted, set at the factory). The device checks the result against its measuring
/// range.
pub const fn wire_raw_um(r: Reading, um_per_turn: u32) -> u32 {
    let whole = r.turns as u64 * um_per_turn as u64;
    let part = r.angle as u64 * um_per_turn as u64 / STEPS_PER_TURN as u64;
    let um = whole + part;
    if um > u32::MAX as u64 {
        u32::MAX
    } else {
        um as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_check_value() {
        // CRC-8/SAE-J1850 check value of "123456789".
        assert_eq!(crc8(b"123456789"), 0x4B);
    }

    #[test]
    fn round_trip_and_faults() {
        let f = encode(3, 0x1234, false, true);
        assert_eq!(decode(&f), Ok(Reading { turns: 3, angle: 0x1234, warning: true }));
        assert_eq!(decode(&encode(3, 5, true, false)), Err(SensorFault::Diagnosis));
        let mut bad = f;
        bad[1] ^= 1;
        assert_eq!(decode(&bad), Err(SensorFault::Diagnosis));
        assert_eq!(decode(&[0; 5]), Err(SensorFault::NoResponse));
        assert_eq!(decode(&[0xFF; 5]), Err(SensorFault::NoResponse));
    }

    #[test]
    fn raw_counts() {
        let r = Reading { turns: 0x1005, angle: 100, warning: false };
        assert_eq!(multiturn_raw(r, 12), 5 * 16384 + 100);
        assert_eq!(multiturn_raw(r, 0), 100);
        assert_eq!(multiturn_raw(Reading { turns: 4095, angle: 16383, warning: false }, 12), 67_108_863);
        assert_eq!(wire_raw_um(Reading { turns: 2, angle: 8192, warning: false }, 150_000), 375_000);
        assert_eq!(wire_raw_um(Reading { turns: u16::MAX, angle: 0, warning: false }, u32::MAX), u32::MAX);
    }
}
