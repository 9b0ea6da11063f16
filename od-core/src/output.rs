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

/// How many outputs may wait for the shell. A node produces at most a handful per frame
/// or tick; the shell drains the queue after each call.
pub const OUTBOX_DEPTH: usize = 32;

/// Outputs waiting for the shell.
#[derive(Clone, Default)]
pub struct Outbox {
    q: heapless::Deque<Output, OUTBOX_DEPTH>,
}

impl Outbox {
    /// Queues an output. When the shell has not drained the queue the oldest frame is kept
    /// and the new one dropped, as a full CAN transmit mailbox would.
    pub fn push(&mut self, out: Output) {
        let _ = self.q.push_back(out);
    }

    /// Queues a frame.
    pub fn send(&mut self, frame: Frame) {
        self.push(Output::Frame(frame));
    }

    /// Takes the oldest output.
    pub fn pop(&mut self) -> Option<Output> {
        self.q.pop_front()
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}
