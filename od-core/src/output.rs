//! What a node asks of its shell: the outputs, and the queue they wait in.

use crate::bitrate::Bitrate;
use crate::frame::Frame;
use crate::od::GroupMask;

/// Something the shell must do for the node.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Output {
    /// Put this frame on the bus.
    Frame(Frame),
    /// Persist the current values of these parameter groups, then report the result with
    /// `store_done` ([`crate::shell::Station::store_done`]).
    Store(GroupMask),
    /// Switch the CAN controller to this bit rate now (the node sends and receives nothing
    /// meanwhile).
    SetBitrate(Bitrate),
}

/// The most frames one call into a node ([`crate::shell::Station::on_frame`], `poll`,
/// `on_bus_event`, `store_done`) can queue, with the shell draining the outbox after each call
/// as every shell does: the boot-up message, every EMCY held until it (up to
/// [`crate::errors::MAX_DEFERRED`]), a heartbeat, one event-timer or SYNC TPDO per TPDO
/// ([`crate::pdo::MAX_TPDOS`]), an SDO answer or timeout abort, a guarding answer, and an EMCY for
/// a change of each error condition the device keeps ([`crate::errors::MAX_ACTIVE`]). The real
/// calls stay far below it (a tick rarely sends more than two); the sum is what the outbox is
/// sized for, so a shell that drains after every call never loses a frame.
pub const WORST_CALL_FRAMES: usize =
    1 + crate::errors::MAX_DEFERRED + 1 + crate::pdo::MAX_TPDOS + 1 + 1 + crate::errors::MAX_ACTIVE;

/// Slots only an [`Output::Store`] or [`Output::SetBitrate`] may take: a node has at most one
/// store under way and switches its bit rate at most once per call, so these two are never
/// dropped, however many frames wait.
const CONTROL_SLOTS: usize = 2;

/// How many outputs may wait for the shell: the worst single call's frames and the two
/// control outputs.
pub const OUTBOX_DEPTH: usize = WORST_CALL_FRAMES + CONTROL_SLOTS;

/// Outputs waiting for the shell: a ring of [`OUTBOX_DEPTH`] slots (a plain array with a head
/// and a length: a push or a pop is a compare, a copy and an index update).
#[derive(Clone)]
pub struct Outbox {
    q: [Output; OUTBOX_DEPTH],
    head: u8,
    len: u8,
    dropped: u32,
}

const _: () = assert!(OUTBOX_DEPTH < u8::MAX as usize);

impl Default for Outbox {
    fn default() -> Self {
        // The filler is never read: only the `len` slots from `head` hold outputs.
        Outbox { q: [Output::SetBitrate(Bitrate::K500); OUTBOX_DEPTH], head: 0, len: 0, dropped: 0 }
    }
}

impl Outbox {
    /// Queues an output. A frame that finds the frame slots full (a shell that has not drained
    /// the queue for several calls) is dropped and counted ([`Outbox::dropped`]), the oldest
    /// frames kept, as a full CAN transmit mailbox would; a [`Output::Store`] or
    /// [`Output::SetBitrate`] always has a slot of its own and is never dropped.
    #[inline(always)]
    pub fn push(&mut self, out: Output) {
        let limit = match out {
            Output::Frame(_) => WORST_CALL_FRAMES,
            Output::Store(_) | Output::SetBitrate(_) => OUTBOX_DEPTH,
        };
        self.put(out, limit);
    }

    /// Queues a frame ([`Outbox::push`]), whose room test needs no look at the variant.
    #[inline(always)]
    pub fn send(&mut self, frame: Frame) {
        self.put(Output::Frame(frame), WORST_CALL_FRAMES);
    }

    /// Queues `out` if fewer than `limit` outputs wait, else counts it dropped.
    #[inline]
    fn put(&mut self, out: Output, limit: usize) {
        let len = self.len as usize;
        if len >= limit {
            self.dropped = self.dropped.wrapping_add(1);
            return;
        }
        let mut at = self.head as usize + len;
        if at >= OUTBOX_DEPTH {
            at -= OUTBOX_DEPTH;
        }
        self.q[at] = out;
        self.len += 1;
    }

    /// Takes the oldest output.
    #[inline]
    pub fn pop(&mut self) -> Option<Output> {
        if self.len == 0 {
            return None;
        }
        let out = self.q[self.head as usize];
        self.head = if self.head as usize + 1 == OUTBOX_DEPTH { 0 } else { self.head + 1 };
        self.len -= 1;
        Some(out)
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// How many outputs were dropped because the shell had not drained the queue (wraps at
    /// 2^32): the shell shows it (the simulator's live view, the firmware's log), since a frame
    /// the node meant to send is gone.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(n: u8) -> Output {
        Output::Frame(Frame::std(0x180 + n as u16, &[n]))
    }

    #[test]
    fn frames_beyond_the_worst_call_are_counted_and_controls_always_fit() {
        let mut out = Outbox::default();
        for n in 0..WORST_CALL_FRAMES {
            out.push(frame(n as u8));
        }
        assert_eq!(out.dropped(), 0, "the worst single call fits");
        out.push(frame(0xFF));
        out.push(frame(0xFE));
        assert_eq!(out.dropped(), 2, "an undrained shell loses frames, counted");
        out.push(Output::Store(GroupMask::ALL));
        out.push(Output::SetBitrate(Bitrate::K125));
        assert_eq!(out.dropped(), 2, "a store and a bit-rate switch are never dropped");
        // The oldest frames are kept, in order, then the controls.
        for n in 0..WORST_CALL_FRAMES {
            assert_eq!(out.pop(), Some(frame(n as u8)));
        }
        assert_eq!(out.pop(), Some(Output::Store(GroupMask::ALL)));
        assert_eq!(out.pop(), Some(Output::SetBitrate(Bitrate::K125)));
        assert!(out.is_empty());
    }

    #[test]
    fn the_ring_keeps_order_across_its_end() {
        let mut out = Outbox::default();
        let mut next_in = 0u32;
        let mut next_out = 0u32;
        for round in 0..200u32 {
            for _ in 0..round % 5 {
                out.push(frame(next_in as u8));
                next_in += 1;
            }
            for _ in 0..(round * 3) % 7 {
                match out.pop() {
                    Some(f) => {
                        assert_eq!(f, frame(next_out as u8));
                        next_out += 1;
                    }
                    None => assert_eq!(next_out, next_in),
                }
            }
            assert_eq!(out.is_empty(), next_in == next_out);
        }
        assert_eq!(out.dropped(), 0);
        assert!(next_out > 100);
    }
}
