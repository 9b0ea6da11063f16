//! The transmit queue: frames wait here for a free transmit mailbox and leave in CAN
//! arbitration order (lowest identifier first; equal identifiers in the order they came).
//!
//! The three bxCAN mailboxes also arbitrate by identifier, but a burst larger than three
//! frames (a boot-up, an EMCY and several TPDOs at one SYNC) must not let a low-priority frame
//! that came first block a higher one: the queue hands the mailboxes the highest-priority
//! frame each time one frees.

use heapless::Vec;
use od_core::frame::{CanId, Frame};

/// Frames the queue holds.
pub const DEPTH: usize = 16;

/// The arbitration priority of a frame: lower wins (base identifier, then 11-bit before
/// 29-bit, then the extension bits, then data before remote). 31 bits: a 32-bit key, so that
/// the queue's comparisons need no 64-bit arithmetic on the Cortex-M3.
pub const fn priority(id: CanId, rtr: bool) -> u32 {
    let (base, ide, ext) = match id {
        CanId::Std(id) => (id as u32 & 0x7FF, 0, 0),
        CanId::Ext(id) => ((id >> 18) & 0x7FF, 1, id & 0x3_FFFF),
    };
    (base << 20) | (ide << 19) | (ext << 1) | rtr as u32
}

/// Frames waiting for a mailbox.
#[derive(Clone, Debug, Default)]
pub struct TxQueue {
    q: Vec<(u32, u32, Frame), DEPTH>,
    seq: u32,
    dropped: u32,
}

impl TxQueue {
    /// Queues a frame. When the queue is full the lowest-priority frame (the new one, if it
    /// is that) is dropped and counted.
    pub fn push(&mut self, frame: Frame) {
        let key = priority(frame.id, frame.rtr);
        self.seq = self.seq.wrapping_add(1);
        if self.q.is_full() {
            self.dropped = self.dropped.saturating_add(1);
            let worst = self.worst();
            match worst {
                Some(i) if self.q[i].0 > key => {
                    self.take(i);
                }
                _ => return,
            }
        }
        let _ = self.q.push((key, self.seq, frame));
    }

    /// Sort key: priority, then the older frame first (larger age).
    fn key(&self, i: usize) -> (u32, core::cmp::Reverse<u32>) {
        (self.q[i].0, core::cmp::Reverse(self.seq.wrapping_sub(self.q[i].1)))
    }

    fn best(&self) -> Option<usize> {
        self.extreme(false)
    }

    fn worst(&self) -> Option<usize> {
        self.extreme(true)
    }

    /// The entry with the smallest key, or the largest if `largest` (one loop for both: the
    /// keys are distinct, as no two entries have one sequence number).
    fn extreme(&self, largest: bool) -> Option<usize> {
        let mut pick: Option<usize> = None;
        for i in 0..self.q.len() {
            if pick.is_none_or(|p| (self.key(i) > self.key(p)) == largest) {
                pick = Some(i);
            }
        }
        pick
    }

    /// The frame to send next, without taking it.
    pub fn peek(&self) -> Option<&Frame> {
        self.best().map(|i| &self.q[i].2)
    }

    /// Takes the frame to send next.
    pub fn pop(&mut self) -> Option<Frame> {
        let i = self.best()?;
        Some(self.take(i).2)
    }

    /// Takes entry `i`, the last one moving into its place (`Vec::swap_remove` without the
    /// overlapping copy that links a 1.6 KiB `memmove` into the image).
    fn take(&mut self, i: usize) -> (u32, u32, Frame) {
        let last = self.q.len() - 1;
        if i < last {
            let (low, high) = self.q.split_at_mut(last);
            core::mem::swap(&mut low[i], &mut high[0]);
        }
        self.q.pop().expect("take of an entry the queue holds")
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Frames dropped because the queue was full.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Drops every waiting frame (bit-rate switch, bus-off with a reset).
    pub fn clear(&mut self) {
        self.q.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arbitration_order() {
        assert!(priority(CanId::Std(0x080), false) < priority(CanId::Std(0x081), false));
        assert!(priority(CanId::Std(0x701), false) < priority(CanId::Std(0x701), true));
        // 11-bit beats a 29-bit identifier with the same base.
        assert!(priority(CanId::Std(0x100), false) < priority(CanId::Ext(0x100 << 18), false));
        assert!(priority(CanId::Ext(0x0FF << 18 | 0x3FFFF), false) < priority(CanId::Std(0x100), false));
        // A remote 11-bit frame still beats the 29-bit ones with its base (IDE after SRR).
        assert!(priority(CanId::Std(0x100), true) < priority(CanId::Ext(0x100 << 18), false));
        // Extension bits in order, remote last, the widest key below 2^31.
        assert!(priority(CanId::Ext(0x1FFF_FFFE), true) < priority(CanId::Ext(0x1FFF_FFFF), false));
        assert!(priority(CanId::Std(0x7FF), true) < priority(CanId::Ext(0x1FFF_FFFF), true));
        assert_eq!(priority(CanId::Ext(0x1FFF_FFFF), true), 0x7FFF_FFFF);
    }

    #[test]
    fn highest_priority_first_then_fifo() {
        let mut q = TxQueue::default();
        q.push(Frame::std(0x701, &[0x7F]));
        q.push(Frame::std(0x181, &[1]));
        q.push(Frame::std(0x081, &[0; 8]));
        q.push(Frame::std(0x181, &[2]));
        assert_eq!(q.pop().unwrap().id, CanId::Std(0x081));
        assert_eq!(q.pop().unwrap().data[0], 1);
        assert_eq!(q.pop().unwrap().data[0], 2);
        assert_eq!(q.pop().unwrap().id, CanId::Std(0x701));
        assert!(q.pop().is_none());
    }

    #[test]
    fn extremes_are_the_smallest_and_largest_keys() {
        // Against `min_by_key` / `max_by_key` over many fillings, the sequence number wrapping.
        let mut x = 12345u32;
        let mut q = TxQueue { seq: u32::MAX - 40, ..TxQueue::default() };
        for _ in 0..2000 {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
            if x >> 30 == 0 {
                q.pop();
            } else {
                q.push(Frame::std(0x180 + (x >> 20) as u16 % 8, &[]));
            }
            let n = q.q.len();
            assert_eq!(q.best(), (0..n).min_by_key(|&i| q.key(i)));
            assert_eq!(q.worst(), (0..n).max_by_key(|&i| q.key(i)));
        }
    }

    #[test]
    fn full_queue_keeps_the_important_frames() {
        let mut q = TxQueue::default();
        for i in 0..DEPTH as u16 {
            q.push(Frame::std(0x300 + i, &[]));
        }
        q.push(Frame::std(0x080, &[]));
        q.push(Frame::std(0x7FF, &[]));
        assert_eq!(q.len(), DEPTH);
        assert_eq!(q.dropped(), 2);
        assert_eq!(q.pop().unwrap().id, CanId::Std(0x080));
        let mut last = 0;
        while let Some(f) = q.pop() {
            assert!(f.id.raw() > last && f.id.raw() < 0x30F);
            last = f.id.raw();
        }
    }
}
