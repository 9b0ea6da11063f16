//! The receive queue: the bxCAN's receive interrupt moves each frame out of the hardware FIFO
//! (three frames deep) into this ring at once, and the main loop takes them in order between
//! two turns. A frame that finds the ring full is dropped and the ring remembers it
//! ([`RxRing::take_overflow`]): the firmware reports it as the hardware FIFO's own overrun is
//! reported, one `BusEvent::RxOverrun` however many were lost (D-FW-9), so no loss is silent.

use od_core::frame::{CanId, Frame};

/// Frames the ring holds between two turns of the loop.
pub const DEPTH: usize = 32;

/// A ring of received frames, oldest first.
#[derive(Clone, Debug)]
pub struct RxRing {
    frames: [Frame; DEPTH],
    /// Index of the oldest frame.
    head: usize,
    /// Frames held.
    len: usize,
    /// A frame was dropped since the last [`RxRing::take_overflow`].
    overflow: bool,
}

impl Default for RxRing {
    fn default() -> Self {
        RxRing::new()
    }
}

impl RxRing {
    /// An empty ring (a `const fn`, for a `static`).
    pub const fn new() -> RxRing {
        const EMPTY: Frame = Frame { id: CanId::Std(0), rtr: false, len: 0, data: [0; 8] };
        RxRing { frames: [EMPTY; DEPTH], head: 0, len: 0, overflow: false }
    }

    /// Adds a frame after the newest; drops it, and remembers the loss, if the ring is full.
    pub fn push(&mut self, frame: Frame) {
        if self.len == DEPTH {
            self.overflow = true;
            return;
        }
        self.frames[(self.head + self.len) % DEPTH] = frame;
        self.len += 1;
    }

    /// Takes the oldest frame.
    pub fn pop(&mut self) -> Option<Frame> {
        if self.len == 0 {
            return None;
        }
        let frame = self.frames[self.head];
        self.head = (self.head + 1) % DEPTH;
        self.len -= 1;
        Some(frame)
    }

    /// Was a frame dropped since the last call? Clears the mark.
    pub fn take_overflow(&mut self) -> bool {
        core::mem::take(&mut self.overflow)
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_in_first_out_across_the_wrap() {
        let mut r = RxRing::new();
        let mut next_in = 0u16;
        let mut next_out = 0u16;
        // Fill and drain in uneven steps (each a permutation of 1..=7 per seven rounds, so the
        // ring never overflows), head and tail passing the end of the array many times.
        for round in 0..100 {
            for _ in 0..(round * 3 % 7 + 1) {
                r.push(Frame::std(next_in, &next_in.to_le_bytes()));
                next_in += 1;
            }
            for _ in 0..(round * 5 % 7 + 1) {
                match r.pop() {
                    Some(f) => {
                        assert_eq!(f, Frame::std(next_out, &next_out.to_le_bytes()));
                        next_out += 1;
                    }
                    None => assert_eq!(next_out, next_in),
                }
            }
        }
        while let Some(f) = r.pop() {
            assert_eq!(f.id, CanId::Std(next_out));
            next_out += 1;
        }
        assert_eq!(next_out, next_in);
        assert!(r.is_empty());
    }

    #[test]
    fn a_full_ring_drops_the_newest() {
        let mut r = RxRing::default();
        for i in 0..DEPTH as u16 + 3 {
            r.push(Frame::std(i, &[]));
        }
        for i in 0..DEPTH as u16 {
            assert_eq!(r.pop().unwrap().id, CanId::Std(i), "the oldest kept");
        }
        assert_eq!(r.pop(), None);
        assert!(r.take_overflow(), "the loss is remembered");
        assert!(!r.take_overflow(), "and reported once");
    }

    #[test]
    fn a_ring_that_never_fills_reports_no_loss() {
        let mut r = RxRing::new();
        for i in 0..DEPTH as u16 {
            r.push(Frame::std(i, &[]));
        }
        assert!(!r.take_overflow());
        r.pop();
        r.push(Frame::std(0, &[]));
        assert!(!r.take_overflow());
    }
}
