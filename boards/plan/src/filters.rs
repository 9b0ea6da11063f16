//! The bxCAN acceptance filters: exactly the identifiers the node handles, nothing else.
//!
//! The node's receive identifiers ([`od_core::Node::rx_ids`]: the core says what it handles,
//! data or remote frame each) are packed into filter banks in identifier-list mode ([`banks`]):
//! four 11-bit identifiers per bank in 16-bit list mode, two 29-bit ones per bank in 32-bit
//! list mode. The STM32F103 has 14 banks (56 standard identifiers), far more than a node
//! needs; should a list not fit, a single bank accepts everything and the core sorts the
//! frames out, as it does on the host. The firmware re-programs the banks whenever the list
//! changes (node-ID, SYNC or RPDO COB-ID written, LSS activation).

use heapless::Vec;
use od_core::frame::{CanId, RxId};
use od_core::node::MAX_RX_IDS;

/// Filter banks of the STM32F103's single bxCAN.
pub const BANKS: usize = 14;

/// Most receive identifiers a node lists ([`od_core::Node::rx_ids`]).
pub const MAX_IDS: usize = MAX_RX_IDS;

/// The 16-bit list-mode entry of `r` (RM0008 figure 230: `STID[10:0] RTR IDE EXID[17:15]`);
/// `None` for a 29-bit identifier.
pub const fn entry16(r: RxId) -> Option<u16> {
    match r.id {
        CanId::Std(id) => Some(((id & 0x7FF) << 5) | if r.rtr { 1 << 4 } else { 0 }),
        CanId::Ext(_) => None,
    }
}

/// The 32-bit list-mode entry of `r` (STID/EXID, IDE, RTR).
pub const fn entry32(r: RxId) -> u32 {
    let rtr = if r.rtr { 1 << 1 } else { 0 };
    match r.id {
        CanId::Std(id) => ((id as u32 & 0x7FF) << 21) | rtr,
        CanId::Ext(id) => ((id & 0x1FFF_FFFF) << 3) | (1 << 2) | rtr,
    }
}

/// The registers of a 32-bit mask-mode bank that passes the 29-bit frames whose identifier
/// matches `id` where `mask` has a one (a J1939 node's masks): both with IDE set, so only
/// 29-bit frames pass; RTR left free.
pub const fn mask32(id: u32, mask: u32) -> (u32, u32) {
    const IDE: u32 = 1 << 2;
    (((id & 0x1FFF_FFFF) << 3) | IDE, ((mask & 0x1FFF_FFFF) << 3) | IDE)
}

/// How one filter bank is programmed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Bank {
    /// 16-bit identifier list: four entries ([`entry16`]); an unused place repeats the first
    /// entry.
    List16([RxId; 4]),
    /// 32-bit identifier list: two entries ([`entry32`]); an unused place repeats the first.
    List32([RxId; 2]),
    /// 32-bit mask mode, mask 0: every frame (only when the identifiers do not fit).
    AcceptAll,
}

impl Bank {
    /// The bank's two filter registers (CAN_FiR1, CAN_FiR2).
    pub const fn registers(&self) -> (u32, u32) {
        match self {
            Bank::List16(e) => (pack16(e[0], e[1]), pack16(e[2], e[3])),
            Bank::List32(e) => (entry32(e[0]), entry32(e[1])),
            Bank::AcceptAll => (0, 0),
        }
    }

    /// The bank's mode bits: (identifier-list mode rather than mask mode: CAN_FM1R,
    /// one 32-bit filter rather than two 16-bit ones: CAN_FS1R).
    pub const fn mode(&self) -> (bool, bool) {
        (!matches!(self, Bank::AcceptAll), !matches!(self, Bank::List16(_)))
    }

    /// Does this bank accept the frame (`id`, remote or not)?
    pub fn accepts(&self, id: CanId, rtr: bool) -> bool {
        let r = RxId { id, rtr };
        match self {
            Bank::List16(e) => e.contains(&r),
            Bank::List32(e) => e.contains(&r),
            Bank::AcceptAll => true,
        }
    }
}

const fn pack16(lo: RxId, hi: RxId) -> u32 {
    let l = match entry16(lo) {
        Some(v) => v,
        None => 0,
    };
    let h = match entry16(hi) {
        Some(v) => v,
        None => 0,
    };
    l as u32 | ((h as u32) << 16)
}

/// Packs `ids` into at most `max_banks` banks: the 11-bit identifiers four to a bank, then
/// the 29-bit ones two to a bank. When they need more than `max_banks`, one bank that accepts
/// every frame instead. ([`each_bank`], collected.)
pub fn banks(ids: &[RxId], max_banks: usize) -> Vec<Bank, BANKS> {
    let mut out: Vec<Bank, BANKS> = Vec::new();
    each_bank(ids, max_banks, |bank| {
        let _ = out.push(bank);
    });
    out
}

/// The banks [`banks`] packs `ids` into, handed to `bank` one by one in bank order (the
/// firmware programs each as it comes, without a list of them on its stack).
pub fn each_bank(ids: &[RxId], max_banks: usize, mut bank: impl FnMut(Bank)) {
    let max = max_banks.min(BANKS);
    if max == 0 {
        return;
    }
    let is_std = |r: &&RxId| matches!(r.id, CanId::Std(_));
    let std = ids.iter().filter(is_std).count();
    let needed = std.div_ceil(4) + (ids.len() - std).div_ceil(2);
    if needed > max {
        // Overflow: fall back to software filtering for everything. (Partial hardware
        // filtering beside an accept-all bank would filter nothing.)
        bank(Bank::AcceptAll);
        return;
    }
    // Four 11-bit identifiers to a bank, then two 29-bit ones; a bank's unused places repeat
    // its first identifier. (Built in place rather than through collected lists, whose moves
    // link a `memmove` into the image.)
    // The standard identifiers four to a 16-bit list bank, then the extended ones two to a
    // 32-bit one; a bank's unused entries repeat its first identifier.
    for std in [true, false] {
        let width = if std { 4 } else { 2 };
        let mut list = [RxId::data(CanId::Std(0)); 4];
        let mut n = 0;
        let mut emit = |list: [RxId; 4]| bank(if std { Bank::List16(list) } else { Bank::List32([list[0], list[1]]) });
        for r in ids.iter().filter(|r| is_std(r) == std) {
            if n == 0 {
                list = [*r; 4];
            }
            list[n] = *r;
            n += 1;
            if n == width {
                emit(list);
                n = 0;
            }
        }
        if n > 0 {
            emit(list);
        }
    }
}

/// Does a filter set accept the frame?
pub fn accepted(banks: &[Bank], id: CanId, rtr: bool) -> bool {
    banks.iter().any(|b| b.accepts(id, rtr))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(id: u16) -> RxId {
        RxId::data(CanId::Std(id))
    }

    #[test]
    fn entries_follow_rm0008() {
        assert_eq!(entry16(data(0x601)), Some(0x601 << 5));
        assert_eq!(entry16(RxId::remote(CanId::Std(0x701))), Some((0x701 << 5) | 0x10));
        assert_eq!(entry32(data(0x7E5)), 0x7E5 << 21);
        assert_eq!(entry32(RxId::remote(CanId::Std(0x7E5))), (0x7E5 << 21) | 2);
        assert_eq!(entry32(RxId::data(CanId::Ext(0x18FF_0012))), (0x18FF_0012 << 3) | 4);
        assert_eq!(entry16(RxId::data(CanId::Ext(1))), None);
    }

    #[test]
    fn modes_and_masks_follow_rm0008() {
        assert_eq!(Bank::List16([data(1); 4]).mode(), (true, false));
        assert_eq!(Bank::List32([data(1); 2]).mode(), (true, true));
        assert_eq!(Bank::AcceptAll.mode(), (false, true));
        assert_eq!(Bank::AcceptAll.registers(), (0, 0), "mask 0: every frame");
        // PGN FECAh to anyone from any source: identifier bits 8..25, IDE bit 2 in both.
        assert_eq!(mask32(0x00FE_CA00, 0x03FF_FF00), ((0x00FE_CA00 << 3) | 4, (0x03FF_FF00 << 3) | 4));
        assert_eq!(mask32(0xFFFF_FFFF, 0), ((0x1FFF_FFFF << 3) | 4, 4), "29 bits only");
    }

    #[test]
    fn five_standard_ids_take_two_banks() {
        let ids = [data(0), data(0x80), data(0x601), RxId::remote(CanId::Std(0x701)), data(0x7E5)];
        let b = banks(&ids, BANKS);
        assert_eq!(b.len(), 2);
        assert_eq!(b[0], Bank::List16([ids[0], ids[1], ids[2], ids[3]]));
        assert_eq!(b[1], Bank::List16([ids[4]; 4]));
        assert_eq!(b[0].registers(), (0x80 << 5 << 16, (0x601 << 5) | (((0x701 << 5) | 0x10) << 16)));
        for r in ids {
            assert!(accepted(&b, r.id, r.rtr));
        }
        assert!(!accepted(&b, CanId::Std(0x701), false), "guarding is RTR only");
        assert!(!accepted(&b, CanId::Std(0x601), true));
        assert!(!accepted(&b, CanId::Std(0x602), false));
        assert!(!accepted(&b, CanId::Ext(0x601), false));
    }

    #[test]
    fn extended_ids_go_to_32_bit_banks() {
        let ids = [data(0), RxId::data(CanId::Ext(0x1234_5678))];
        let b = banks(&ids, BANKS);
        assert_eq!(b.len(), 2);
        assert_eq!(b[1], Bank::List32([ids[1], ids[1]]));
        assert!(accepted(&b, CanId::Ext(0x1234_5678), false));
        assert!(!accepted(&b, CanId::Std(0x678), false));
    }

    #[test]
    fn overflow_accepts_everything() {
        let ids: Vec<RxId, MAX_IDS> = (0..9).map(|i| data(0x200 + i)).collect();
        assert_eq!(banks(&ids, 3).len(), 3);
        let b = banks(&ids, 2);
        assert_eq!(b.as_slice(), &[Bank::AcceptAll]);
        assert!(accepted(&b, CanId::Std(0x555), false));
        assert!(banks(&ids, 0).is_empty());
    }
}
