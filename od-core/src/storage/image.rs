//! The parameter image: the stored values as records keyed by (index, sub-index), and its
//! byte layout in one flash page.
//!
//! ```text
//! offset  size  field
//!      0     8  commit marker (COMMIT), written last: the page counts only once it is there
//!      8     4  magic "SKPI"
//!     12     2  format version (VERSION; VERSION_1 pages still load)
//!     14     2  number of records n
//!     16     4  device identity (`identity`: an image of another device is refused)
//!     20     4  sequence number (the newest valid page wins)
//!     24     4  reserved, FFFFFFFFh
//!     28     4  CRC-32 over bytes 8..28 and the n records
//!     32    8n  records: index (2), sub-index (1), size in bytes (1), value (4)
//! 32 + 8n       version 2 only: the log, entries of 8-byte units up to the end of the page
//! ```
//!
//! A log entry is the records one save changed (a record of size 0 removes its key: the entry
//! went back to its default) followed by its commit unit, written last:
//!
//! ```text
//!      0     2  0000h (no entry has index 0000h)
//!      2     1  number of records k of the entry (1..=255), the k units before this one
//!      3     1  LOG_TAG
//!      4     4  CRC-32 over the page's sequence number (4 bytes), the k records and bytes 0..4
//! ```
//!
//! The image a page holds is its records with every committed entry applied in order; the log
//! ends at the first unit that reads erased (FFh), at the page's end, or at the first entry that
//! does not check (a save a power cut interrupted: nothing after it counts, and the next save
//! starts a new page, as it does when anything after the first erased unit is not erased). Version 1 (the format before the log) is the same page without a log.
//!
//! All numbers little-endian. A record names its entry instead of a position in the table, so a
//! firmware that adds or removes entries still loads every record that matches one of its
//! entries (same size, value within the entry's limits) and ignores the rest.

use crate::od::{CoreHook, DataType, Entry, Hook};

use super::crc::Crc32;

/// Most records an image holds. The largest dictionary (AP10T) stores under 50 entries; the
/// rest is room for firmware updates. 32 + 96 x 8 = 800 bytes: one 1 KiB STM32F1 page.
pub const MAX_RECORDS: usize = 96;
/// Bytes of one record.
pub const RECORD_SIZE: usize = 8;
/// Bytes before the first record (commit marker and header).
pub const HEADER_SIZE: usize = 32;
/// Bytes of the commit marker at the start of a slot.
pub const COMMIT_SIZE: usize = 8;
/// The commit marker. Neither erased (FFh) nor zeroed (00h) flash, nor a torn write of it, can
/// read as this pattern.
pub const COMMIT: [u8; COMMIT_SIZE] = *b"\xA5\x5A\xC3\x3CPARM";
/// "SKPI": SIKO parameter image.
pub const MAGIC: [u8; 4] = *b"SKPI";
/// Layout version written: a page that may carry a log after its records. Firmware that knows
/// only [`VERSION_1`] refuses it rather than load its records without their log.
pub const VERSION: u16 = 2;
/// The layout before the log (the same header and records, nothing after them): still loads.
pub const VERSION_1: u16 = 1;
/// Bytes of one log unit (a record or a commit).
pub const UNIT: usize = 8;
/// Byte 3 of a log commit unit (never a record's size: those are 0, 1, 2 or 4).
pub const LOG_TAG: u8 = 0xC3;

/// Bytes a slot needs for an image of `records` records.
pub const fn slot_size(records: usize) -> usize {
    HEADER_SIZE + records * RECORD_SIZE
}

/// One stored value.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Record {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Size of the entry's data type in bytes when it was stored.
    pub size: u8,
    /// The raw 32-bit slot value.
    pub value: u32,
}

impl Record {
    /// The record of `value` for entry `e`.
    pub const fn of(e: &Entry, value: u32) -> Record {
        Record { index: e.index, sub: e.sub, size: e.dtype.size() as u8, value }
    }

    /// Its bytes in a slot.
    pub fn encode(&self) -> [u8; RECORD_SIZE] {
        let mut b = [0u8; RECORD_SIZE];
        b[..2].copy_from_slice(&self.index.to_le_bytes());
        b[2] = self.sub;
        b[3] = self.size;
        b[4..].copy_from_slice(&self.value.to_le_bytes());
        b
    }

    /// The record these bytes hold.
    pub fn decode(b: &[u8; RECORD_SIZE]) -> Record {
        Record {
            index: u16::from_le_bytes([b[0], b[1]]),
            sub: b[2],
            size: b[3],
            value: u32::from_le_bytes([b[4], b[5], b[6], b[7]]),
        }
    }

    /// May this record set entry `e` (same key, a stored entry, same size, a value the entry
    /// accepts)? A record the current firmware cannot take is skipped, never half-applied.
    pub fn fits(&self, e: &Entry) -> bool {
        if (self.index, self.sub) != (e.index, e.sub)
            || !super::is_stored(e)
            || e.string_value().is_some()
            || self.size as usize != e.dtype.size()
        {
            return false;
        }
        if e.dtype == DataType::Boolean && self.value > 1 {
            return false;
        }
        // LSS may store the pending node-ID FFh, "unconfigured" (CiA 305), outside the entry's
        // SDO limits: such a node powers on answering LSS only.
        if e.hook == Hook::Core(CoreHook::PendingNodeId) && self.value == crate::lss::UNCONFIGURED as u32 {
            return true;
        }
        match e.limits() {
            Some((lo, hi)) => (lo..=hi).contains(&e.dtype.to_i64(self.value)),
            None => true,
        }
    }

    /// A log record that removes the record of (index, sub): size 0.
    pub const fn removal(index: u16, sub: u8) -> Record {
        Record { index, sub, size: 0, value: 0 }
    }

    /// Is it a log record that removes its key?
    pub const fn is_removal(&self) -> bool {
        self.size == 0
    }

    pub(crate) fn key(&self) -> (u16, u8) {
        (self.index, self.sub)
    }
}

/// Is this log unit a commit (rather than a record)?
pub fn is_log_commit(unit: &[u8; UNIT]) -> bool {
    unit[0] == 0 && unit[1] == 0 && unit[3] == LOG_TAG
}

/// The commit unit of a log entry of `count` records whose CRC `crc` has digested the page's
/// sequence number and the records: it digests the unit's first four bytes and ends in the sum.
pub fn log_commit(count: u8, mut crc: Crc32) -> [u8; UNIT] {
    let mut unit = [0, 0, count, LOG_TAG, 0, 0, 0, 0];
    crc.update(&unit[..4]);
    unit[4..].copy_from_slice(&crc.finish().to_le_bytes());
    unit
}

/// The CRC a log entry of the page with sequence number `sequence` starts from.
pub fn log_crc(sequence: u32) -> Crc32 {
    let mut crc = Crc32::new();
    crc.update(&sequence.to_le_bytes());
    crc
}

/// [`Image::header`] of an image of `records` records, its CRC field still FFFFFFFFh.
pub(crate) fn head(records: usize, identity: u32, sequence: u32) -> [u8; HEADER_SIZE - COMMIT_SIZE] {
    let mut h = [0xFFu8; HEADER_SIZE - COMMIT_SIZE];
    let words = [u32::from_le_bytes(MAGIC), VERSION as u32 | (records as u32) << 16, identity, sequence];
    for (bytes, word) in h.as_chunks_mut::<4>().0.iter_mut().zip(words) {
        *bytes = word.to_le_bytes();
    }
    h
}

/// What a page's header says, once its records check ([`Image::decode_slot`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Slot {
    /// Sequence number.
    pub sequence: u32,
    /// Layout version ([`VERSION`] or [`VERSION_1`]).
    pub version: u16,
    /// Number of records before the log.
    pub records: usize,
}

/// The image is full ([`MAX_RECORDS`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Full;

/// A parameter image: records sorted by (index, sub-index), at most one per key.
#[derive(Clone, Default, PartialEq, Eq, Debug)]
pub struct Image {
    records: heapless::Vec<Record, MAX_RECORDS>,
}

impl Image {
    /// An empty image (every stored entry at its default).
    pub const fn new() -> Image {
        Image { records: heapless::Vec::new() }
    }

    /// The records, sorted.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// No records?
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Where the record for (index, sub) is (`Ok`) or would go (`Err`): a linear search,
    /// smaller than a binary one, and an image holds a few dozen records at most.
    fn find(&self, index: u16, sub: u8) -> Result<usize, usize> {
        let key = super::key(index, sub);
        for (i, r) in self.records.iter().enumerate() {
            let k = super::key(r.index, r.sub);
            if k >= key {
                return if k == key { Ok(i) } else { Err(i) };
            }
        }
        Err(self.records.len())
    }

    /// The record for (index, sub), if any.
    pub fn get(&self, index: u16, sub: u8) -> Option<&Record> {
        self.find(index, sub).ok().map(|i| &self.records[i])
    }

    /// The value this image gives entry `e`, if it holds a record that fits it.
    pub fn value_for(&self, e: &Entry) -> Option<u32> {
        self.get(e.index, e.sub).filter(|r| r.fits(e)).map(|r| r.value)
    }

    /// Adds or replaces the record with `rec`'s key.
    pub fn set(&mut self, rec: Record) -> Result<(), Full> {
        self.update(rec, false)
    }

    /// Removes the record for (index, sub), if any.
    pub fn remove(&mut self, index: u16, sub: u8) {
        let _ = self.update(Record::removal(index, sub), true);
    }

    /// Sets `rec`, or with `remove` removes its key. Records move one swap at a time:
    /// `Vec::insert`'s overlapping copy would link a 1.6 KiB `memmove` into the firmware.
    #[inline(never)]
    pub(crate) fn update(&mut self, rec: Record, remove: bool) -> Result<(), Full> {
        let found = self.find(rec.index, rec.sub);
        let v = &mut self.records;
        match found {
            Ok(i) if !remove => {
                // (Through get_mut: find's index is in range, no bounds-check panic.)
                if let Some(slot) = v.get_mut(i) {
                    *slot = rec;
                }
            }
            Ok(mut i) => {
                // Moved up to the end, then dropped.
                while i + 1 < v.len() {
                    v.swap(i, i + 1);
                    i += 1;
                }
                v.pop();
            }
            Err(_) if remove => {}
            Err(i) => {
                // Appended, then moved down into place.
                v.push(rec).map_err(|_| Full)?;
                let mut at = v.len() - 1;
                while at > i {
                    v.swap(at - 1, at);
                    at -= 1;
                }
            }
        }
        Ok(())
    }

    /// Makes this image a copy of `other` (copying only the records it holds).
    pub fn assign(&mut self, other: &Image) {
        self.records.clear();
        // Same capacity: the records always fit.
        let _ = self.records.extend_from_slice(&other.records);
    }

    /// Keeps only the records `keep` approves.
    pub fn retain(&mut self, keep: impl FnMut(&Record) -> bool) {
        self.records.retain(keep);
    }

    /// Appends a record read from a slot; false unless keys strictly increase and there is room.
    pub(crate) fn push_sorted(&mut self, rec: Record) -> bool {
        let ordered = self.records.last().is_none_or(|l| l.key() < rec.key());
        ordered && self.push(rec).is_ok()
    }

    /// Appends a record whose key is above every key held.
    pub(crate) fn push(&mut self, rec: Record) -> Result<(), Full> {
        self.records.push(rec).map_err(|_| Full)
    }

    /// Bytes 8..32 of the slot that holds this image: magic, version, count, identity,
    /// sequence, reserved, CRC.
    pub fn header(&self, identity: u32, sequence: u32) -> [u8; HEADER_SIZE - COMMIT_SIZE] {
        let mut h = head(self.records.len(), identity, sequence);
        let mut crc = Crc32::new();
        crc.update(&h[..20]);
        for r in &self.records {
            crc.update(&r.encode());
        }
        h[20..24].copy_from_slice(&crc.finish().to_le_bytes());
        h
    }

    /// Writes the whole committed slot into `buf`; returns its length, or `None` if `buf` is
    /// too short. (The flash layer writes the same bytes piecewise, commit marker last.)
    pub fn encode(&self, identity: u32, sequence: u32, buf: &mut [u8]) -> Option<usize> {
        let len = slot_size(self.records.len());
        let out = buf.get_mut(..len)?;
        out[..COMMIT_SIZE].copy_from_slice(&COMMIT);
        out[COMMIT_SIZE..HEADER_SIZE].copy_from_slice(&self.header(identity, sequence));
        for (chunk, r) in out[HEADER_SIZE..].chunks_exact_mut(RECORD_SIZE).zip(&self.records) {
            chunk.copy_from_slice(&r.encode());
        }
        Some(len)
    }

    /// Reads a slot from `bytes` (see [`Image::decode_with`]).
    pub fn decode(bytes: &[u8], identity: u32) -> Result<(Image, u32), DecodeError> {
        let mut image = Image::new();
        let sequence = Image::decode_with(
            |at, out| match bytes.get(at..at + out.len()) {
                Some(src) => {
                    out.copy_from_slice(src);
                    true
                }
                None => false,
            },
            bytes.len(),
            identity,
            Some(&mut image),
        )?;
        Ok((image, sequence))
    }

    /// Checks the slot that `read(offset, buf)` reads (`capacity` bytes long) and returns its
    /// sequence number; fills `out` with its records if given. `read` returns false when the
    /// bytes cannot be read.
    pub fn decode_with(
        read: impl FnMut(usize, &mut [u8]) -> bool,
        capacity: usize,
        identity: u32,
        out: Option<&mut Image>,
    ) -> Result<u32, DecodeError> {
        Image::decode_slot(read, capacity, identity, out).map(|slot| slot.sequence)
    }

    /// [`Image::decode_with`], returning the whole header: sequence, version, record count. The
    /// log after the records (version 2) is the flash layer's.
    pub fn decode_slot(
        mut read: impl FnMut(usize, &mut [u8]) -> bool,
        capacity: usize,
        identity: u32,
        mut out: Option<&mut Image>,
    ) -> Result<Slot, DecodeError> {
        let mut head = [0u8; HEADER_SIZE];
        if capacity < HEADER_SIZE || !read(0, &mut head) {
            return Err(DecodeError::Unreadable);
        }
        if head[..COMMIT_SIZE] != COMMIT {
            // Programming only clears bits: a marker still on its way from FFh to COMMIT is an
            // erased page or a save cut short; any other pattern was not written by us.
            let on_its_way = head[..COMMIT_SIZE].iter().zip(&COMMIT).all(|(&b, &c)| b & c == c);
            return Err(if on_its_way { DecodeError::Uncommitted } else { DecodeError::Marker });
        }
        let h = &head[COMMIT_SIZE..];
        if h[0..4] != MAGIC {
            return Err(DecodeError::Magic);
        }
        let word = |at: usize| u32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]]);
        let version = u16::from_le_bytes([h[4], h[5]]);
        if version != VERSION && version != VERSION_1 {
            return Err(DecodeError::Version);
        }
        let count = u16::from_le_bytes([h[6], h[7]]) as usize;
        if count > MAX_RECORDS || slot_size(count) > capacity {
            return Err(DecodeError::Length);
        }
        let mut crc = Crc32::new();
        crc.update(&h[..20]);
        if let Some(image) = out.as_deref_mut() {
            *image = Image::new();
        }
        for i in 0..count {
            let mut b = [0u8; RECORD_SIZE];
            if !read(HEADER_SIZE + i * RECORD_SIZE, &mut b) {
                return Err(DecodeError::Unreadable);
            }
            crc.update(&b);
            if let Some(image) = out.as_deref_mut() {
                if !image.push_sorted(Record::decode(&b)) {
                    return Err(DecodeError::Order);
                }
            }
        }
        if crc.finish() != word(20) {
            return Err(DecodeError::Crc);
        }
        // Checked after the CRC: a foreign image is intact, just not ours.
        if word(8) != identity {
            return Err(DecodeError::Foreign);
        }
        Ok(Slot { sequence: word(12), version, records: count })
    }
}

/// Why a slot holds no usable image.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum DecodeError {
    /// The slot could not be read (or is shorter than a header).
    Unreadable,
    /// No commit marker yet: erased, or a save that did not finish.
    Uncommitted,
    /// Something else where the commit marker belongs (zeroed, garbage, or a page a failed
    /// save invalidated).
    Marker,
    /// Not a parameter image.
    Magic,
    /// An image layout this firmware does not know.
    Version,
    /// More records than fit.
    Length,
    /// Records out of order (only an image not written by us can have that).
    Order,
    /// Checksum mismatch: corrupt or torn.
    Crc,
    /// An intact image of another device.
    Foreign,
}

/// The device identity an image is bound to: CRC-32 of the device type (1000h), vendor-ID and
/// product code (1018h.01/.02) and device name (1008h) as declared. The dictionary's layout is
/// deliberately not part of it, so that images survive firmware updates.
///
/// A `const fn`: the firmware computes its image's identity at compile time.
pub const fn identity(table: &[Entry]) -> u32 {
    // Each key as the CRC digests it: index (little-endian), sub-index.
    const KEYS: [[u8; 3]; 4] = [[0x00, 0x10, 0], [0x18, 0x10, 1], [0x18, 0x10, 2], [0x08, 0x10, 0]];
    let mut crc = Crc32::new();
    let mut k = 0;
    while k < KEYS.len() {
        let key = &KEYS[k];
        let (index, sub) = (u16::from_le_bytes([key[0], key[1]]), key[2]);
        let mut i = 0;
        // The first entry with the key, if declared.
        while i < table.len() && !(table[i].index == index && table[i].sub == sub) {
            i += 1;
        }
        if i < table.len() {
            let e = &table[i];
            crc = crc.digest(key);
            let value = e.default_value(0).to_le_bytes();
            crc = crc.digest(match e.string_value() {
                Some(s) => s,
                None => &value,
            });
        }
        k += 1;
    }
    crc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::sgh10;

    fn sample() -> Image {
        let mut i = Image::new();
        i.set(Record { index: 0x6000, sub: 0, size: 2, value: 0x000C }).unwrap();
        i.set(Record { index: 0x1017, sub: 0, size: 2, value: 100 }).unwrap();
        i.set(Record { index: 0x5F0A, sub: 1, size: 1, value: 5 }).unwrap();
        i
    }

    #[test]
    fn records_stay_sorted_and_unique() {
        let mut i = sample();
        i.set(Record { index: 0x1017, sub: 0, size: 2, value: 200 }).unwrap();
        let keys: heapless::Vec<(u16, u8), 8> = i.records().iter().map(|r| (r.index, r.sub)).collect();
        assert_eq!(&keys[..], &[(0x1017, 0), (0x5F0A, 1), (0x6000, 0)]);
        assert_eq!(i.get(0x1017, 0).unwrap().value, 200);
        i.remove(0x5F0A, 1);
        assert_eq!(i.len(), 2);
        i.remove(0x5F0A, 1);
        assert_eq!(i.len(), 2);
    }

    #[test]
    fn encode_decode_round_trip() {
        let id = identity(sgh10::TABLE);
        let mut buf = [0xFFu8; 1024];
        let n = sample().encode(id, 7, &mut buf).unwrap();
        assert_eq!(n, 32 + 3 * 8);
        assert_eq!(&buf[..8], &COMMIT);
        assert_eq!(&buf[8..12], b"SKPI");
        // First record: 1017h.00, 2 bytes, 100.
        assert_eq!(&buf[32..40], &[0x17, 0x10, 0x00, 0x02, 100, 0, 0, 0]);
        assert_eq!(Image::decode(&buf, id), Ok((sample(), 7)));
        assert_eq!(Image::decode(&buf[..n], id), Ok((sample(), 7)));
    }

    #[test]
    fn empty_image_is_valid() {
        let mut buf = [0u8; HEADER_SIZE];
        assert_eq!(Image::new().encode(1, 1, &mut buf), Some(HEADER_SIZE));
        assert_eq!(Image::decode(&buf, 1), Ok((Image::new(), 1)));
    }

    #[test]
    fn refuses_foreign_truncated_corrupt_and_blank() {
        let id = identity(sgh10::TABLE);
        let mut buf = [0xFFu8; 1024];
        let n = sample().encode(id, 1, &mut buf).unwrap();
        assert_eq!(Image::decode(&buf, id ^ 1), Err(DecodeError::Foreign));
        assert_eq!(Image::decode(&buf[..n - 1], id), Err(DecodeError::Length));
        assert_eq!(Image::decode(&buf[..20], id), Err(DecodeError::Unreadable));
        for i in 8..n {
            let mut bad = buf;
            bad[i] ^= 0x10;
            assert!(Image::decode(&bad, id).is_err(), "byte {i} flipped");
        }
        let mut bad = buf;
        bad[3] = 0;
        assert_eq!(Image::decode(&bad, id), Err(DecodeError::Marker));
        let mut unfinished = buf;
        unfinished[4..8].fill(0xFF);
        assert_eq!(Image::decode(&unfinished, id), Err(DecodeError::Uncommitted));
        assert_eq!(Image::decode(&[0xFF; 1024], id), Err(DecodeError::Uncommitted));
        assert_eq!(Image::decode(&[0x00; 1024], id), Err(DecodeError::Marker));
        let mut v3 = buf;
        v3[12] = 3;
        assert_eq!(Image::decode(&v3, id), Err(DecodeError::Version));
        let mut long = buf;
        long[14..16].copy_from_slice(&(MAX_RECORDS as u16 + 1).to_le_bytes());
        assert_eq!(Image::decode(&long, id), Err(DecodeError::Length));
    }

    #[test]
    fn unsorted_records_are_refused_even_with_a_good_crc() {
        let id = 9;
        let mut buf = [0xFFu8; 128];
        let n = sample().encode(id, 1, &mut buf).unwrap();
        // Swap the first two records and fix the CRC: still refused.
        let (a, b) = buf[32..48].split_at_mut(8);
        a.swap_with_slice(b);
        let mut crc = Crc32::new();
        crc.update(&buf[8..28]);
        crc.update(&buf[32..n]);
        buf[28..32].copy_from_slice(&crc.finish().to_le_bytes());
        assert_eq!(Image::decode(&buf, id), Err(DecodeError::Order));
    }

    #[test]
    fn identity_tells_devices_apart() {
        use crate::od::{Access, DataType, Entry};
        static OTHER: &[Entry] = &[
            Entry::var(0x1000, "Device type", DataType::Unsigned32, Access::Const, 0x000A_0196),
            Entry::string(0x1008, "Name", "SGH50"),
        ];
        assert_ne!(identity(sgh10::TABLE), identity(OTHER));
        assert_eq!(identity(sgh10::TABLE), identity(sgh10::TABLE));
    }

    /// The identity as it was computed before it became a `const fn` (a search of the table
    /// per key, the CRC fed piece by piece): every image already on a device carries it.
    fn identity_by_search(table: &[Entry]) -> u32 {
        let mut crc = Crc32::new();
        for k in [[0x00, 0x10, 0], [0x18, 0x10, 1], [0x18, 0x10, 2], [0x08, 0x10, 0]] {
            if let Some(e) = table.iter().find(|e| [e.index.to_le_bytes()[0], e.index.to_le_bytes()[1], e.sub] == k) {
                crc.update(&k);
                let value = e.default_value(0).to_le_bytes();
                crc.update(e.string_value().unwrap_or(&value));
            }
        }
        crc.finish()
    }

    #[test]
    fn identity_at_compile_time_is_the_one_images_carry() {
        use crate::devices::{ap10t, sgh50, wv5800m, wv58mr};
        use wv5800m::{Model, Turns, Variant};
        const SGH10: u32 = identity(sgh10::TABLE);
        assert_eq!(SGH10, identity_by_search(sgh10::TABLE));
        for table in [sgh10::TABLE, sgh50::TABLE, ap10t::table::TABLE] {
            assert_eq!(identity(table), identity_by_search(table));
        }
        for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
            for model in [Model::Wv, Model::Wh] {
                let table = wv5800m::table_of(Variant { model, turns });
                assert_eq!(identity(table), identity_by_search(table));
            }
            assert_eq!(identity(wv58mr::table_of(turns)), identity_by_search(wv58mr::table_of(turns)));
        }
    }

    #[test]
    fn records_fit_only_matching_entries() {
        let od = crate::od::Od::new(sgh10::TABLE, 1);
        let e = |i, s| od.entry(od.pos(i, s).unwrap());
        let nid = e(0x5F0A, 1);
        assert!(Record::of(nid, 5).fits(nid));
        assert!(!Record::of(nid, 0).fits(nid), "below the limits");
        assert!(!Record::of(nid, 128).fits(nid), "above the limits");
        assert!(!Record { size: 2, ..Record::of(nid, 5) }.fits(nid), "type changed");
        assert!(!Record::of(nid, 5).fits(e(0x5F0A, 2)), "other key");
        let vendor = e(0x1018, 1);
        assert!(!Record::of(vendor, 0x195).fits(vendor), "not a stored entry");
        let low = e(0x6401, 1);
        assert!(Record::of(low, -20478i32 as u32).fits(low));
        assert!(!Record::of(low, -20479i32 as u32).fits(low));
    }
}
