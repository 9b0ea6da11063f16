//! The bxCAN transmit mailboxes: a frame as their registers hold it (RM0008 24.9.3, CAN_TIxR,
//! CAN_TDTxR, CAN_TDLxR, CAN_TDHxR), and which mailbox the most urgent waiting frame goes to.
//!
//! The mailboxes arbitrate among themselves by identifier, so the firmware hands them the
//! queue's most urgent frame ([`crate::txq`]) whenever one is free. When all three hold frames
//! that the bus does not take (a busy bus, or no other node to acknowledge), a more urgent frame
//! takes the place of the least urgent one, which goes back into the queue; a frame no more
//! urgent than all three waits, so two frames never swap places for ever. A frame whose
//! identifier is already in a mailbox waits too: the bxCAN would not keep the two in order.

use crate::filters::entry32;
use crate::txq::priority;
use od_core::frame::{CanId, Frame, RxId};

/// CAN_TIxR: transmit request.
pub const TXRQ: u32 = 1;
/// CAN_TIxR: remote frame.
const RTR: u32 = 1 << 1;
/// CAN_TIxR: 29-bit identifier.
const IDE: u32 = 1 << 2;

/// A frame's mailbox registers: identifier (TXRQ clear), data length, data bytes 0-3 and 4-7
/// (little-endian, as the bxCAN sends them).
pub fn registers(frame: &Frame) -> [u32; 4] {
    let d = frame.data;
    [
        entry32(RxId { id: frame.id, rtr: frame.rtr }),
        (frame.len & 0xF) as u32,
        u32::from_le_bytes([d[0], d[1], d[2], d[3]]),
        u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
    ]
}

/// The identifier and remote flag of an identifier register.
pub const fn id_of(tir: u32) -> (CanId, bool) {
    let id = if tir & IDE != 0 { CanId::Ext(tir >> 3) } else { CanId::Std((tir >> 21) as u16) };
    (id, tir & RTR != 0)
}

/// The arbitration priority ([`priority`]) of the frame an identifier register holds, from the
/// register's bits: STID (or EXID 28..18) at 31..21, EXID 17..0 at 20..3 (zero for an 11-bit
/// identifier), IDE at 2, RTR at 1.
pub const fn tir_priority(tir: u32) -> u32 {
    ((tir >> 21) << 20) | (((tir & IDE) >> 2) << 19) | (((tir >> 3) & 0x3_FFFF) << 1) | ((tir & RTR) >> 1)
}

/// The frame a mailbox holds (one taken back out of it).
pub fn frame_of([tir, tdtr, tdlr, tdhr]: [u32; 4]) -> Frame {
    let (id, rtr) = id_of(tir);
    let len = ((tdtr & 0xF) as u8).min(8);
    if rtr {
        Frame::remote(id, len)
    } else {
        let [a, b, c, d] = tdlr.to_le_bytes();
        let [e, f, g, h] = tdhr.to_le_bytes();
        Frame::new(id, &[a, b, c, d, e, f, g, h][..len as usize])
    }
}

/// Where the most urgent waiting frame goes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Slot {
    /// Into this free mailbox.
    Free(usize),
    /// Into this mailbox, whose less urgent frame is aborted and goes back into the queue.
    Replace(usize),
    /// Nowhere yet.
    Wait,
}

/// Where `frame` goes, given the identifier registers of the pending mailboxes (`None`: free).
pub fn choose(frame: &Frame, mailboxes: [Option<u32>; 3]) -> Slot {
    let own = entry32(RxId { id: frame.id, rtr: frame.rtr });
    let mut free = None;
    let mut least = None;
    for (i, tir) in mailboxes.into_iter().enumerate() {
        match tir {
            // The same identifier is pending: after it, never beside it.
            Some(tir) if tir & !TXRQ == own => return Slot::Wait,
            Some(tir) => {
                let key = tir_priority(tir);
                if least.is_none_or(|(_, k)| key > k) {
                    least = Some((i, key));
                }
            }
            None => free = free.or(Some(i)),
        }
    }
    match (free, least) {
        (Some(i), _) => Slot::Free(i),
        (None, Some((i, key))) if priority(frame.id, frame.rtr) < key => Slot::Replace(i),
        _ => Slot::Wait,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tir(frame: &Frame) -> Option<u32> {
        Some(registers(frame)[0] | TXRQ)
    }

    #[test]
    fn tir_priority_is_the_frames_priority() {
        let ids = [
            CanId::Std(0),
            CanId::Std(0x080),
            CanId::Std(0x601),
            CanId::Std(0x7FF),
            CanId::Ext(0),
            CanId::Ext(0x18EE_FF80),
            CanId::Ext(0x1FFF_FFFF),
            CanId::Ext(0x0004_0000),
            CanId::Ext(0x0003_FFFF),
        ];
        for id in ids {
            for rtr in [false, true] {
                let tir = entry32(RxId { id, rtr });
                assert_eq!(tir_priority(tir), priority(id, rtr), "{id:?} {rtr}");
                assert_eq!(tir_priority(tir | TXRQ), priority(id, rtr));
            }
        }
    }

    #[test]
    fn registers_follow_rm0008() {
        let f = Frame::std(0x70A, &[0x7F]);
        assert_eq!(registers(&f), [0x70A << 21, 1, 0x7F, 0]);
        let f = Frame::new(CanId::Ext(0x18EE_FF80), &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(registers(&f), [(0x18EE_FF80 << 3) | IDE, 8, 0x0403_0201, 0x0807_0605]);
        let f = Frame::remote(CanId::Std(0x70A), 1);
        assert_eq!(registers(&f), [(0x70A << 21) | RTR, 1, 0, 0]);
    }

    #[test]
    fn frames_come_back_as_they_went_in() {
        for f in [
            Frame::std(0, &[]),
            Frame::std(0x7FF, &[0xAA; 8]),
            Frame::std(0x181, &[1, 2, 3]),
            Frame::new(CanId::Ext(0x1FFF_FFFF), &[9, 8, 7, 6, 5]),
            Frame::new(CanId::Ext(0), &[]),
            Frame::remote(CanId::Std(0x701), 1),
            Frame::remote(CanId::Ext(0x1234_5678), 8),
        ] {
            let mut r = registers(&f);
            r[0] |= TXRQ;
            assert_eq!(frame_of(r), f);
        }
        // A DLC above 8 means 8 bytes.
        assert_eq!(frame_of([0x100 << 21, 15, 1, 2]).len, 8);
    }

    #[test]
    fn free_mailboxes_first() {
        let f = Frame::std(0x181, &[1]);
        assert_eq!(choose(&f, [None; 3]), Slot::Free(0));
        assert_eq!(choose(&f, [tir(&Frame::std(0x701, &[])), None, None]), Slot::Free(1));
        // Less urgent than what is pending, but a mailbox is free: it goes (the mailboxes
        // arbitrate among themselves).
        let urgent = tir(&Frame::std(0x080, &[]));
        assert_eq!(choose(&f, [urgent, urgent, None]), Slot::Free(2));
    }

    #[test]
    fn equal_identifiers_wait() {
        let f = Frame::std(0x181, &[2]);
        assert_eq!(choose(&f, [None, tir(&Frame::std(0x181, &[1])), None]), Slot::Wait);
        // Data and remote frames of one identifier are different frames on the bus.
        assert_eq!(choose(&f, [tir(&Frame::remote(CanId::Std(0x181), 0)), None, None]), Slot::Free(1));
    }

    #[test]
    fn full_mailboxes_give_way_only_to_a_more_urgent_frame() {
        let boxes = [
            tir(&Frame::std(0x281, &[])),
            tir(&Frame::std(0x701, &[])), // the least urgent
            tir(&Frame::std(0x181, &[])),
        ];
        assert_eq!(choose(&Frame::std(0x080, &[]), boxes), Slot::Replace(1));
        assert_eq!(choose(&Frame::std(0x700, &[]), boxes), Slot::Replace(1));
        assert_eq!(choose(&Frame::std(0x702, &[]), boxes), Slot::Wait);
        assert_eq!(choose(&Frame::remote(CanId::Std(0x701), 0), boxes), Slot::Wait, "remote after data");
        assert_eq!(choose(&Frame::new(CanId::Ext(0x701 << 18), &[]), boxes), Slot::Wait, "29-bit after 11-bit");
        assert_eq!(choose(&Frame::std(0x701, &[]), boxes), Slot::Wait);
    }

    #[test]
    fn a_replaced_frame_does_not_swap_back() {
        // The frame taken out goes back into the queue; offered again, it must wait for the
        // frame that replaced it rather than replace it in turn.
        let mut boxes = [tir(&Frame::std(0x300, &[])), tir(&Frame::std(0x200, &[])), tir(&Frame::std(0x100, &[]))];
        let urgent = Frame::std(0x150, &[]);
        let Slot::Replace(i) = choose(&urgent, boxes) else { panic!("more urgent") };
        let back = frame_of([boxes[i].unwrap(), 0, 0, 0]);
        assert_eq!(back.id, CanId::Std(0x300));
        boxes[i] = tir(&urgent);
        assert_eq!(choose(&back, boxes), Slot::Wait);
    }
}
