//! The bxCAN acceptance filters: exactly the identifiers the node handles, nothing else.
//!
//! The node's receive identifiers ([`receive_ids`]: NMT, SYNC, SDO request, node-guarding
//! RTR, LSS, receive PDOs) are packed into filter banks in identifier-list mode ([`banks`]):
//! four 11-bit identifiers per bank in 16-bit list mode, two 29-bit ones per bank in 32-bit
//! list mode. The STM32F103 has 14 banks (56 standard identifiers), far more than a node
//! needs; should a list not fit, the last bank accepts everything and the core sorts the
//! frames out, as it does on the host. The firmware re-programs the banks whenever the list
//! changes (node-ID, SYNC or RPDO COB-ID written, LSS activation).

use heapless::Vec;
use od_core::frame::CanId;
use od_core::node::Core;

/// Filter banks of the STM32F103's single bxCAN.
pub const BANKS: usize = 14;

/// Most receive identifiers a node has: NMT, SYNC, SDO, guarding, LSS and up to 11 RPDOs.
pub const MAX_IDS: usize = 16;

/// The LSS slave's request identifier (CiA 305).
pub const LSS_RX: u16 = 0x7E5;

/// One identifier the node receives, as a data or a remote frame.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
pub struct RxId {
    /// The identifier.
    pub id: CanId,
    /// Remote frames (node guarding) rather than data frames.
    pub rtr: bool,
}

impl RxId {
    /// Data frames with the 11-bit identifier `id`.
    pub const fn data(id: u16) -> RxId {
        RxId { id: CanId::Std(id), rtr: false }
    }

    /// Remote frames with the 11-bit identifier `id`.
    pub const fn remote(id: u16) -> RxId {
        RxId { id: CanId::Std(id), rtr: true }
    }

    /// The 16-bit list-mode entry (RM0008 figure 230: STID[10:0] RTR IDE EXID[17:15]);
    /// `None` for a 29-bit identifier.
    pub const fn entry16(self) -> Option<u16> {
        match self.id {
            CanId::Std(id) => Some(((id & 0x7FF) << 5) | if self.rtr { 1 << 4 } else { 0 }),
            CanId::Ext(_) => None,
        }
    }

    /// The 32-bit list-mode entry (STID/EXID, IDE, RTR).
    pub const fn entry32(self) -> u32 {
        let rtr = if self.rtr { 1 << 1 } else { 0 };
        match self.id {
            CanId::Std(id) => ((id as u32 & 0x7FF) << 21) | rtr,
            CanId::Ext(id) => ((id & 0x1FFF_FFFF) << 3) | (1 << 2) | rtr,
        }
    }
}

/// The identifiers the node behind `core` must receive: NMT (000h); with a node-ID, the
/// SYNC COB-ID (1005h), the SDO request (600h + node-ID), the node-guarding RTR (700h +
/// node-ID) and every valid receive PDO COB-ID (1400h..15FFh sub 1, bit 31 clear); LSS (7E5h)
/// when the node has an LSS slave. Sorted, without duplicates.
pub fn receive_ids(core: &Core) -> Vec<RxId, MAX_IDS> {
    let mut ids: Vec<RxId, MAX_IDS> = Vec::new();
    let mut add = |r: RxId| {
        if !ids.contains(&r) {
            let _ = ids.push(r);
        }
    };
    add(RxId::data(0x000));
    if core.lss.enabled() {
        add(RxId::data(LSS_RX));
    }
    if core.configured() {
        let id = core.node_id as u16;
        add(RxId::data(0x600 + id));
        add(RxId::remote(0x700 + id));
        if let Some(sync) = core.od.value(0x1005, 0) {
            add(RxId { id: CanId::from_cob_id(sync), rtr: false });
        }
        for index in 0x1400..=0x15FF {
            if let Some(cob) = core.od.value(index, 1) {
                if cob & (1 << 31) == 0 {
                    add(RxId { id: CanId::from_cob_id(cob), rtr: false });
                }
            }
        }
    }
    ids.sort_unstable();
    ids
}

/// How one filter bank is programmed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Bank {
    /// 16-bit identifier list: four entries ([`RxId::entry16`]); an unused place repeats the
    /// first entry.
    List16([RxId; 4]),
    /// 32-bit identifier list: two entries ([`RxId::entry32`]); an unused place repeats the first.
    List32([RxId; 2]),
    /// 32-bit mask mode, mask 0: every frame (only when the identifiers do not fit).
    AcceptAll,
}

impl Bank {
    /// The bank's two filter registers (CAN_FiR1, CAN_FiR2).
    pub const fn registers(&self) -> (u32, u32) {
        match self {
            Bank::List16(e) => (pack16(e[0], e[1]), pack16(e[2], e[3])),
            Bank::List32(e) => (e[0].entry32(), e[1].entry32()),
            Bank::AcceptAll => (0, 0),
        }
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
    let l = match lo.entry16() {
        Some(v) => v,
        None => 0,
    };
    let h = match hi.entry16() {
        Some(v) => v,
        None => 0,
    };
    l as u32 | ((h as u32) << 16)
}

/// Packs `ids` into at most `max_banks` banks: the 11-bit identifiers four to a bank, then
/// the 29-bit ones two to a bank. When they need more than `max_banks`, the banks that fit
/// are kept and the last one accepts every frame.
pub fn banks(ids: &[RxId], max_banks: usize) -> Vec<Bank, BANKS> {
    let max = max_banks.min(BANKS);
    let mut out: Vec<Bank, BANKS> = Vec::new();
    if max == 0 {
        return out;
    }
    let std: Vec<RxId, MAX_IDS> = ids.iter().copied().filter(|r| matches!(r.id, CanId::Std(_))).collect();
    let ext: Vec<RxId, MAX_IDS> = ids.iter().copied().filter(|r| matches!(r.id, CanId::Ext(_))).collect();
    let needed = std.len().div_ceil(4) + ext.len().div_ceil(2);
    if needed > max {
        // Overflow: fall back to software filtering for everything. (Partial hardware
        // filtering beside an accept-all bank would filter nothing.)
        let _ = out.push(Bank::AcceptAll);
        return out;
    }
    for chunk in std.chunks(4) {
        let mut e = [chunk[0]; 4];
        e[..chunk.len()].copy_from_slice(chunk);
        let _ = out.push(Bank::List16(e));
    }
    for chunk in ext.chunks(2) {
        let mut e = [chunk[0]; 2];
        e[..chunk.len()].copy_from_slice(chunk);
        let _ = out.push(Bank::List32(e));
    }
    out
}

/// Does a filter set accept the frame?
pub fn accepted(banks: &[Bank], id: CanId, rtr: bool) -> bool {
    banks.iter().any(|b| b.accepts(id, rtr))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_follow_rm0008() {
        assert_eq!(RxId::data(0x601).entry16(), Some(0x601 << 5));
        assert_eq!(RxId::remote(0x701).entry16(), Some((0x701 << 5) | 0x10));
        assert_eq!(RxId::data(0x7E5).entry32(), 0x7E5 << 21);
        assert_eq!(RxId { id: CanId::Ext(0x18FF_0012), rtr: false }.entry32(), (0x18FF_0012 << 3) | 4);
        assert_eq!(RxId { id: CanId::Ext(1), rtr: false }.entry16(), None);
    }

    #[test]
    fn five_standard_ids_take_two_banks() {
        let ids = [RxId::data(0), RxId::data(0x80), RxId::data(0x601), RxId::remote(0x701), RxId::data(0x7E5)];
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
        let ids = [RxId::data(0), RxId { id: CanId::Ext(0x1234_5678), rtr: false }];
        let b = banks(&ids, BANKS);
        assert_eq!(b.len(), 2);
        assert_eq!(b[1], Bank::List32([ids[1], ids[1]]));
        assert!(accepted(&b, CanId::Ext(0x1234_5678), false));
        assert!(!accepted(&b, CanId::Std(0x678), false));
    }

    #[test]
    fn overflow_accepts_everything() {
        let ids: Vec<RxId, MAX_IDS> = (0..9).map(|i| RxId::data(0x200 + i)).collect();
        assert_eq!(banks(&ids, 3).len(), 3);
        let b = banks(&ids, 2);
        assert_eq!(b.as_slice(), &[Bank::AcceptAll]);
        assert!(accepted(&b, CanId::Std(0x555), false));
        assert!(banks(&ids, 0).is_empty());
    }
}
