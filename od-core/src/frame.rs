//! CAN frames as the core sees them: an identifier, a remote flag and up to eight data bytes.

/// A CAN identifier: 11-bit standard or 29-bit extended.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub enum CanId {
    /// 11-bit identifier (0..=0x7FF).
    Std(u16),
    /// 29-bit identifier (0..=0x1FFF_FFFF).
    Ext(u32),
}

impl CanId {
    /// The raw identifier value, without any frame-format flag.
    pub const fn raw(self) -> u32 {
        match self {
            CanId::Std(id) => id as u32,
            CanId::Ext(id) => id,
        }
    }

    /// The identifier as one number, the format in bit 31 (set for 29-bit): what a hot path
    /// compares in one instruction. No identifier has the key `u32::MAX`.
    #[inline(always)]
    pub const fn key(self) -> u32 {
        match self {
            CanId::Std(id) => id as u32,
            CanId::Ext(id) => id | 1 << 31,
        }
    }

    /// The identifier whose [`CanId::key`] is `key`; `None` for `u32::MAX` (no identifier).
    pub const fn from_key(key: u32) -> Option<CanId> {
        if key == u32::MAX {
            None
        } else if key & 1 << 31 != 0 {
            Some(CanId::Ext(key & 0x1FFF_FFFF))
        } else {
            Some(CanId::Std(key as u16))
        }
    }

    /// The identifier a CANopen COB-ID entry (1005h, 1014h, 18xxh.01 ...) designates:
    /// bit 29 selects the 29-bit format, the low bits are the identifier.
    pub const fn from_cob_id(cob_id: u32) -> CanId {
        if cob_id & (1 << 29) != 0 {
            CanId::Ext(cob_id & 0x1FFF_FFFF)
        } else {
            CanId::Std((cob_id & 0x7FF) as u16)
        }
    }

    /// A CAN-ID that CiA 301 §7.3.5 (table 70) reserves for NMT, SYNC/EMCY defaults, SDO,
    /// NMT error control and LSS: no configurable COB-ID (1005h, 1014h, 14xxh, 18xxh) may use one.
    pub const fn is_restricted(self) -> bool {
        match self {
            CanId::Std(id) => {
                matches!(id, 0x000 | 0x001..=0x07F | 0x101..=0x180 | 0x581..=0x5FF | 0x601..=0x67F | 0x6E0..=0x6FF | 0x701..=0x77F | 0x780..=0x7FF)
            }
            CanId::Ext(_) => false,
        }
    }

    /// True for an 11-bit identifier equal to `id`.
    pub const fn is_std(self, id: u16) -> bool {
        matches!(self, CanId::Std(x) if x == id)
    }
}

/// One kind of frame a node receives: an identifier, as a data frame or as a remote frame. The
/// node's list of them ([`crate::Node::rx_ids`]) is what a shell programs into its CAN
/// controller's acceptance filters.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct RxId {
    /// The identifier.
    pub id: CanId,
    /// Remote frames rather than data frames.
    pub rtr: bool,
}

impl RxId {
    /// Data frames with identifier `id`.
    pub const fn data(id: CanId) -> RxId {
        RxId { id, rtr: false }
    }

    /// Remote frames with identifier `id`.
    pub const fn remote(id: CanId) -> RxId {
        RxId { id, rtr: true }
    }
}

/// A quick test of whether a node may act on a standard identifier: a 64-bit set of hashed
/// identifiers built from the node's receive list ([`crate::Node::rx_ids`]). An identifier not
/// in the set is certainly not on the list, so the node drops the frame after one multiply and
/// one bit test (issue 14's W5, a frame for another node); one in the set goes on to the full
/// dispatch, which decides. With the dozen identifiers a node receives, about one foreign
/// identifier in five passes. Extended identifiers always pass.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct RxFilter {
    bits: u64,
}

impl RxFilter {
    /// Lets every frame through.
    pub const OPEN: RxFilter = RxFilter { bits: u64::MAX };

    #[inline(always)]
    const fn bit(id: u16) -> u64 {
        1 << ((id as u32).wrapping_mul(0x9E37_79B1) >> 26)
    }

    /// The filter of a receive list.
    #[inline(never)]
    pub fn new(ids: &[RxId]) -> RxFilter {
        let mut bits = 0;
        for rx in ids {
            bits |= match rx.id {
                CanId::Std(id) => RxFilter::bit(id),
                CanId::Ext(_) => 0,
            };
        }
        RxFilter { bits }
    }

    /// May the node act on a frame with identifier `id`? False only for identifiers not on
    /// the list the filter was built from.
    #[inline(always)]
    pub fn passes(self, id: CanId) -> bool {
        match id {
            CanId::Std(id) => self.bits & RxFilter::bit(id) != 0,
            CanId::Ext(_) => true,
        }
    }
}

/// One CAN 2.0 frame.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Frame {
    /// Identifier.
    pub id: CanId,
    /// Remote transmission request: no data, `len` is the requested DLC.
    pub rtr: bool,
    /// Data length code, 0..=8.
    pub len: u8,
    /// Payload; bytes past `len` are zero.
    pub data: [u8; 8],
}

impl Frame {
    /// A data frame. Bytes beyond the eighth are dropped.
    #[inline]
    pub fn new(id: CanId, payload: &[u8]) -> Frame {
        let len = payload.len().min(8);
        let mut data = [0u8; 8];
        data[..len].copy_from_slice(&payload[..len]);
        Frame { id, rtr: false, len: len as u8, data }
    }

    /// A data frame with an 11-bit identifier.
    #[inline]
    pub fn std(id: u16, payload: &[u8]) -> Frame {
        Frame::new(CanId::Std(id), payload)
    }

    /// A remote frame requesting `len` bytes.
    pub fn remote(id: CanId, len: u8) -> Frame {
        Frame { id, rtr: true, len: len.min(8), data: [0; 8] }
    }

    /// The valid payload bytes (empty for a remote frame).
    #[inline]
    pub fn payload(&self) -> &[u8] {
        if self.rtr {
            &[]
        } else {
            &self.data[..self.len as usize]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::CanId;

    #[test]
    fn keys_round_trip() {
        for id in [CanId::Std(0), CanId::Std(0x7FF), CanId::Ext(0), CanId::Ext(0x1FFF_FFFF), CanId::Ext(0x80)] {
            assert_eq!(CanId::from_key(id.key()), Some(id));
        }
        assert_ne!(CanId::Std(0x80).key(), CanId::Ext(0x80).key());
        assert_eq!(CanId::from_key(u32::MAX), None);
    }

    #[test]
    fn restricted_ids_follow_cia_301_table_70() {
        for id in
            [0x000, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701, 0x77F, 0x780, 0x7FF]
        {
            assert!(CanId::Std(id).is_restricted(), "{id:03X}");
        }
        for id in [0x080, 0x100, 0x181, 0x1FF, 0x580, 0x600, 0x680, 0x6DF, 0x700] {
            assert!(!CanId::Std(id).is_restricted(), "{id:03X}");
        }
        assert!(!CanId::Ext(0x001).is_restricted());
    }
}
