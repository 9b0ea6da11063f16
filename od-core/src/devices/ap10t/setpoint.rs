//! The two set points: what RPDO1/RPDO2 deliver, their validity and acknowledgement, the status
//! word and the TPDO payloads built from them.
//!
//! Reception (D-AP-3, AP10T A6/A7/A25): every RPDO carries the whole control word; its validity
//! bits (2, 9) set both set points' validity, its acknowledgement bits (10, 6) acknowledge
//! (a 0 does not withdraw an acknowledgement), its data identifier (bit 7) belongs to the set
//! point in the same RPDO. A set point that changed (other value or identifier, or valid again
//! after being invalid) starts unacknowledged unless its acknowledgement bit is set; resending
//! the same value keeps an acknowledgement given by key. An invalid set point is never
//! acknowledged.

use super::keys::{Key, KeySet};
use super::words::{cw, sw, StatusWord};

/// Which set point: 1 (upper row, RPDO1/TPDO1) or 2 (lower row, RPDO2/TPDO2).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Which {
    /// Set point 1.
    Sp1,
    /// Set point 2.
    Sp2,
}

impl Which {
    /// 0 for set point 1, 1 for set point 2.
    pub const fn index(self) -> usize {
        match self {
            Which::Sp1 => 0,
            Which::Sp2 => 1,
        }
    }
}

/// One set point as received.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct SetPoint {
    /// RPDO bytes 0-5: a number in bytes 0-3 (INTEGER32, little-endian; 4-5 a dummy), or six
    /// ASCII characters, byte 0 the leftmost.
    pub bytes: [u8; 6],
    /// The data identifier: ASCII text rather than a number.
    pub ascii: bool,
    /// Valid (control word bit 2 / 9).
    pub valid: bool,
    /// Acknowledged, by key or by control word bit 10 / 6.
    pub acknowledged: bool,
}

impl SetPoint {
    /// The numeric value: bytes 0-3 as a two's complement INTEGER32 (AP10T A25).
    pub const fn number(&self) -> i32 {
        i32::from_le_bytes([self.bytes[0], self.bytes[1], self.bytes[2], self.bytes[3]])
    }

    /// Whether `bytes` with identifier `ascii` show something else than `self` (only the bytes
    /// that matter for the type count).
    fn differs(&self, bytes: &[u8; 6], ascii: bool) -> bool {
        // Bytes 0-3 and 4-5 as two words (no byte-slice comparison).
        let head = |b: &[u8; 6]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let tail = |b: &[u8; 6]| u16::from_le_bytes([b[4], b[5]]);
        let (a, b) = (&self.bytes, bytes);
        self.ascii != ascii || head(a) != head(b) || (ascii && tail(a) != tail(b))
    }
}

/// Both set points and the last control word.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct SetPoints {
    /// Set point 1 and set point 2.
    pub sp: [SetPoint; 2],
    /// The control word of the last RPDO (5F0Ch), as its 16 bits (see [`ControlWord`](super::words::ControlWord); kept
    /// raw, each user tests the bits it needs).
    pub control: u16,
}

impl SetPoints {
    /// Nothing received: both invalid, control word 0.
    pub const fn new() -> SetPoints {
        SetPoints { sp: [SetPoint { bytes: [0; 6], ascii: false, valid: false, acknowledged: false }; 2], control: 0 }
    }

    /// One set point.
    pub const fn get(&self, which: Which) -> &SetPoint {
        &self.sp[which.index()]
    }

    /// Takes the 8 data bytes of RPDO1 (`Sp1`) or RPDO2 (`Sp2`).
    pub fn receive(&mut self, which: Which, data: &[u8; 8]) {
        let w = u16::from_le_bytes([data[6], data[7]]);
        let ascii = w & cw::ASCII != 0;
        let mut bytes = [0u8; 6];
        bytes.copy_from_slice(&data[..6]);
        // Validity and acknowledgement bits of set point 1, then set point 2.
        for (i, (valid, ack)) in [(cw::SP1_VALID, cw::SP1_ACK), (cw::SP2_VALID, cw::SP2_ACK)].into_iter().enumerate() {
            let (valid, ack) = (w & valid != 0, w & ack != 0);
            let sp = &mut self.sp[i];
            let mut changed = !sp.valid && valid;
            if i == which.index() {
                changed |= sp.differs(&bytes, ascii);
                sp.bytes = bytes;
                sp.ascii = ascii;
            }
            sp.valid = valid;
            sp.acknowledged = valid && (ack || (sp.acknowledged && !changed));
        }
        self.control = w;
    }

    /// Whether a valid set point waits for its acknowledgement.
    pub fn unacknowledged(&self) -> bool {
        self.sp.iter().any(|s| s.valid && !s.acknowledged)
    }

    /// An acknowledgement key was pressed: every valid set point is acknowledged ("if both
    /// values are unacknowledged, both values will be acknowledged via one keystroke"). Returns
    /// whether anything changed.
    pub fn acknowledge(&mut self) -> bool {
        let mut any = false;
        for sp in self.sp.iter_mut() {
            if sp.valid && !sp.acknowledged {
                sp.acknowledged = true;
                any = true;
            }
        }
        any
    }

    /// The status word 5F19h with the keys `held`; bit 9 (data identifier) is 0.
    pub fn status_word(&self, held: KeySet) -> StatusWord {
        StatusWord::from_bits(self.status_bits(held))
    }

    /// [`SetPoints::status_word`] as its 16 bits.
    pub fn status_bits(&self, held: KeySet) -> u16 {
        let [s1, s2] = self.sp;
        let put = |flag: bool, mask: u16| if flag { mask } else { 0 };
        put(s1.valid, sw::SP1_VALID)
            | put(s1.acknowledged, sw::SP1_ACK)
            | put(s2.valid, sw::SP2_VALID)
            | put(s2.acknowledged, sw::SP2_ACK)
            | put(self.control & cw::GUARDING != 0, sw::GUARDING)
            | put(held.contains(Key::Front), sw::FRONT_KEY)
            | put(held.contains(Key::Left), sw::LEFT_KEY)
            | put(held.contains(Key::Star), sw::STAR_KEY)
            | put(held.contains(Key::Up), sw::UP_KEY)
    }

    /// The 8 data bytes of TPDO1 (`Sp1`) or TPDO2 (`Sp2`): the set point's bytes 0-5 as
    /// received and the status word. `remote`: the answer to a remote request (on a TPDO or
    /// RPDO identifier), which alone carries the data identifier in status word bit 9 (AP10T
    /// A23).
    pub fn tpdo(&self, which: Which, held: KeySet, remote: bool) -> [u8; 8] {
        let sp = self.get(which);
        let mut sw = self.status_word(held);
        sw.ascii = remote && sp.ascii;
        let mut out = [0u8; 8];
        out[..6].copy_from_slice(&sp.bytes);
        out[6..].copy_from_slice(&sw.to_le_bytes());
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::ap10t::keys::Key;

    const NONE: KeySet = KeySet::NONE;

    #[test]
    fn d20_d21_a_number_arrives_unacknowledged() {
        let mut s = SetPoints::new();
        s.receive(Which::Sp1, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
        assert_eq!(s.get(Which::Sp1).number(), 12345);
        assert!(s.get(Which::Sp1).valid && !s.get(Which::Sp1).acknowledged);
        assert_eq!(s.status_word(NONE).bits(), 0x0004);
        // D21: TPDO1 (timer) = the set point bytes and SW 0004h.
        assert_eq!(s.tpdo(Which::Sp1, NONE, false), [0x39, 0x30, 0, 0, 0, 0, 0x04, 0x00]);
    }

    #[test]
    fn d22_d23_key_then_bus_acknowledgement() {
        let mut s = SetPoints::new();
        let d20 = [0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00];
        s.receive(Which::Sp1, &d20);
        assert!(s.acknowledge());
        assert!(!s.acknowledge(), "nothing left to acknowledge");
        // D22: SW 0025h while the front key is held, 0024h after.
        let front = NONE.with(Key::Front, true);
        assert_eq!(s.status_word(front).bits(), 0x0025);
        assert_eq!(s.status_word(NONE).bits(), 0x0024);
        // The master repeats the same value without ack bit: the key's acknowledgement stays.
        s.receive(Which::Sp1, &d20);
        assert_eq!(s.status_word(NONE).bits(), 0x0024);
        // D23: CW 0504h: valid + acknowledged by bus + guarding bit -> SW 0124h in the TPDO.
        s.receive(Which::Sp1, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x05]);
        assert_eq!(s.tpdo(Which::Sp1, NONE, false), [0x39, 0x30, 0, 0, 0, 0, 0x24, 0x01]);
        // A new value without ack bit is unacknowledged again.
        s.receive(Which::Sp1, &[0x3A, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
        assert_eq!(s.status_word(NONE).bits(), 0x0004);
    }

    #[test]
    fn d24_ascii_and_the_data_identifier_only_in_remote_answers() {
        let mut s = SetPoints::new();
        s.receive(Which::Sp1, &[0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x84, 0x00]);
        let sp = s.get(Which::Sp1);
        assert!(sp.ascii && sp.valid);
        assert_eq!(&sp.bytes, b"AP10T ");
        assert_eq!(s.tpdo(Which::Sp1, NONE, false), [0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x04, 0x00]);
        assert_eq!(s.tpdo(Which::Sp1, NONE, true), [0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x04, 0x02]);
        // Set point 2 is a number (never received): bit 9 stays 0 in its remote answer.
        assert_eq!(s.tpdo(Which::Sp2, NONE, true)[6..], [0x04, 0x00]);
    }

    #[test]
    fn d25_d26_set_point_2() {
        let mut s = SetPoints::new();
        s.receive(Which::Sp1, &[0x39, 0x30, 0, 0, 0, 0, 0x04, 0x00]);
        s.receive(Which::Sp2, &[0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x04, 0x02]);
        assert_eq!(s.get(Which::Sp2).number(), -5);
        // SW: SP1 valid (2), SP2 valid (10), nothing acknowledged.
        assert_eq!(s.status_word(NONE).bits(), 0x0404);
        // D26: TPDO2 on SYNC.
        assert_eq!(s.tpdo(Which::Sp2, NONE, false), [0xFB, 0xFF, 0xFF, 0xFF, 0, 0, 0x04, 0x04]);
        // One keystroke acknowledges both.
        assert!(s.acknowledge());
        assert_eq!(s.status_word(NONE).bits(), 0x042C);
    }

    #[test]
    fn the_control_word_of_either_rpdo_acts_on_both_set_points() {
        let mut s = SetPoints::new();
        s.receive(Which::Sp1, &[1, 0, 0, 0, 0, 0, 0x04, 0x00]);
        s.receive(Which::Sp2, &[2, 0, 0, 0, 0, 0, 0x04, 0x02]);
        // RPDO2 acknowledges set point 1 by bit 10 and keeps set point 1's value.
        s.receive(Which::Sp2, &[2, 0, 0, 0, 0, 0, 0x04, 0x06]);
        assert!(s.get(Which::Sp1).acknowledged && !s.get(Which::Sp2).acknowledged);
        assert_eq!(s.get(Which::Sp1).number(), 1);
        // RPDO1 without bit 9 invalidates set point 2, which loses its acknowledgement.
        s.receive(Which::Sp2, &[2, 0, 0, 0, 0, 0, 0x44, 0x02]);
        assert!(s.get(Which::Sp2).acknowledged);
        s.receive(Which::Sp1, &[1, 0, 0, 0, 0, 0, 0x04, 0x00]);
        assert!(!s.get(Which::Sp2).valid && !s.get(Which::Sp2).acknowledged);
        // Valid again with the old value: a new set point for the operator.
        s.receive(Which::Sp1, &[1, 0, 0, 0, 0, 0, 0x04, 0x02]);
        assert!(s.get(Which::Sp2).valid && !s.get(Which::Sp2).acknowledged);
        // An invalid set point cannot be acknowledged, by key or by bus.
        s.receive(Which::Sp1, &[1, 0, 0, 0, 0, 0, 0x00, 0x04]);
        assert!(!s.get(Which::Sp1).acknowledged);
    }

    #[test]
    fn a_number_ignores_the_dummy_bytes_an_identifier_change_is_new() {
        let mut s = SetPoints::new();
        s.receive(Which::Sp1, &[7, 0, 0, 0, 0, 0, 0x04, 0x04]);
        assert!(s.get(Which::Sp1).acknowledged);
        s.receive(Which::Sp1, &[7, 0, 0, 0, 0x12, 0x34, 0x04, 0x00]);
        assert!(s.get(Which::Sp1).acknowledged, "dummy bytes 4-5 do not make a new number");
        s.receive(Which::Sp1, &[7, 0, 0, 0, 0x12, 0x34, 0x84, 0x00]);
        assert!(!s.get(Which::Sp1).acknowledged, "the same bytes as text are a new set point");
    }
}
