//! Finding an (index, sub-index) in a dictionary without searching it.
//!
//! Every SDO request, PDO mapping check and device update names an entry by (index, sub-index).
//! A binary search of a hundred entries costs seven probes, each a load and a compare of
//! scattered table rows; issue 14's hot paths spend a quarter of their time there. The
//! [`Lookup`] built beside the table when an [`crate::od::Od`] is made maps each index to the
//! position of its first row through a small open-addressed hash table (one multiply, usually
//! one probe); the sub-index is then the row `first + sub` whenever the object's sub-indices are
//! dense from 0 (all of them but the rare gapped arrays), else a scan of that object's own rows.
//!
//! The table has [`SLOTS`] one-byte slots (a position, or 255 for none) and is built once at
//! start-up: [`SLOTS`] bytes of RAM for a lookup that costs the same for every entry.

use crate::abort::Abort;
use crate::od::Entry;

/// Hash slots: a power of two, well over twice the most distinct indices a dictionary has (47,
/// the AP10T's), so probe runs stay short; checked by the tests.
pub const SLOTS: usize = 128;

/// A free slot.
const EMPTY: u8 = u8::MAX;

/// Positions are stored in one byte: a dictionary has fewer rows than this.
pub const MAX_ROWS: usize = EMPTY as usize;

/// The slot an index hashes to: Fibonacci hashing, the top bits of a 32-bit product.
#[inline(always)]
const fn slot(index: u16) -> usize {
    ((index as u32).wrapping_mul(0x9E37_79B1) >> (32 - SLOTS.trailing_zeros())) as usize
}

/// The index → first-row map of one dictionary table.
#[derive(Clone)]
pub struct Lookup {
    slots: [u8; SLOTS],
}

impl Lookup {
    /// Builds the map of `table`, sorted by (index, sub) with fewer than [`MAX_ROWS`] rows
    /// (checked by the caller, [`crate::od::Od::new`]).
    pub fn new(table: &[Entry]) -> Lookup {
        let mut slots = [EMPTY; SLOTS];
        let mut prev = None;
        for (pos, e) in table.iter().enumerate() {
            if prev == Some(e.index) {
                continue;
            }
            prev = Some(e.index);
            let mut s = slot(e.index);
            while slots[s] != EMPTY {
                s = (s + 1) % SLOTS;
            }
            slots[s] = pos as u8;
        }
        Lookup { slots }
    }

    /// Position of (index, sub) in `table` (the table this map was built from), or the abort
    /// code an SDO client gets: 06020000h when no entry has that index, 06090011h when the
    /// index exists but not the sub-index.
    #[inline]
    pub fn find(&self, table: &[Entry], index: u16, sub: u8) -> Result<usize, Abort> {
        let mut s = slot(index);
        let first = loop {
            let p = self.slots[s];
            if p == EMPTY {
                return Err(Abort::NO_OBJECT);
            }
            // Every stored position is a row of `table`; `get` keeps a foreign table safe.
            match table.get(p as usize) {
                Some(e) if e.index == index => break p as usize,
                Some(_) => s = (s + 1) % SLOTS,
                None => return Err(Abort::NO_OBJECT),
            }
        };
        // Dense sub-indices from 0: the row is `first + sub`.
        if let Some(e) = table.get(first + sub as usize) {
            if e.index == index && e.sub == sub {
                return Ok(first + sub as usize);
            }
        }
        Self::scan(table, first, index, sub)
    }

    /// The object's rows one by one (a gapped array, or a sub-index past its last row).
    #[cold]
    fn scan(table: &[Entry], first: usize, index: u16, sub: u8) -> Result<usize, Abort> {
        for (pos, e) in table.iter().enumerate().skip(first) {
            if e.index != index || e.sub > sub {
                break;
            }
            if e.sub == sub {
                return Ok(pos);
            }
        }
        Err(Abort::NO_SUBINDEX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::{ap10t, sgh10, sgh50, wv5800m, wv58mr};
    use crate::od::{Access, DataType};

    /// Every dictionary of every device and variant.
    fn all_tables() -> impl Iterator<Item = &'static [Entry]> {
        use wv5800m::{Model, Turns, Variant};
        let turns = [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12];
        let wv = [Model::Wv, Model::Wh]
            .into_iter()
            .flat_map(move |model| turns.into_iter().map(move |turns| wv5800m::table_of(Variant { model, turns })));
        let mr = turns.into_iter().map(wv58mr::table::table_of);
        [sgh10::TABLE, sgh50::TABLE, ap10t::table::TABLE].into_iter().chain(wv).chain(mr)
    }

    /// The reference: a plain search of the sorted table.
    fn search(table: &[Entry], index: u16, sub: u8) -> Result<usize, Abort> {
        match table.iter().position(|e| (e.index, e.sub) == (index, sub)) {
            Some(p) => Ok(p),
            None if table.iter().any(|e| e.index == index) => Err(Abort::NO_SUBINDEX),
            None => Err(Abort::NO_OBJECT),
        }
    }

    /// Every (index, sub) of the 16-bit index space near the declared ones, and every declared
    /// row, agrees with the search, for every device's table.
    #[test]
    fn agrees_with_a_search_on_every_table() {
        for table in all_tables() {
            let map = Lookup::new(table);
            for e in table.iter() {
                for index in [e.index.wrapping_sub(1), e.index, e.index.wrapping_add(1), e.index ^ 0x100] {
                    for sub in 0..=255u8 {
                        assert_eq!(map.find(table, index, sub), search(table, index, sub), "{index:04X}.{sub:02X}");
                    }
                }
            }
            let indices = table.windows(2).filter(|w| w[0].index != w[1].index).count() + 1;
            assert!(indices * 2 <= SLOTS, "{indices} indices for {SLOTS} slots");
            for index in (0..=0xFFFFu16).step_by(7) {
                assert_eq!(map.find(table, index, 0), search(table, index, 0), "{index:04X}.00");
            }
        }
    }

    #[test]
    fn gapped_subindices_and_colliding_indices() {
        // Indices that share a slot, and an array with holes.
        let a = 0x2000u16;
        let b = (0x2001..=0xFFFF).find(|&i| slot(i) == slot(a)).unwrap();
        let table: &[Entry] = &[
            Entry::array(a, "A", 5, Access::Const),
            Entry::member(a, 2, "two", DataType::Unsigned8, Access::Rw, 0),
            Entry::member(a, 5, "five", DataType::Unsigned8, Access::Rw, 0),
            Entry::var(b, "B", DataType::Unsigned8, Access::Rw, 0),
        ];
        let map = Lookup::new(table);
        assert_eq!(map.find(table, a, 0), Ok(0));
        assert_eq!(map.find(table, a, 2), Ok(1));
        assert_eq!(map.find(table, a, 5), Ok(2));
        assert_eq!(map.find(table, a, 1), Err(Abort::NO_SUBINDEX));
        assert_eq!(map.find(table, a, 6), Err(Abort::NO_SUBINDEX));
        assert_eq!(map.find(table, b, 0), Ok(3));
        assert_eq!(map.find(table, b, 1), Err(Abort::NO_SUBINDEX));
        assert_eq!(map.find(table, a + 1, 0), Err(Abort::NO_OBJECT));
    }
}
