//! Heartbeat producer (1017h, CiA 301 §7.2.8.3.2.2).
//!
//! With a producer time of T ms (0 = off; 1..9 are refused, as every manual allows only 0 and
//! 10..65535) the node sends 700h + node-ID with its NMT state (05h OPERATIONAL, 7Fh
//! PRE-OPERATIONAL, 04h STOPPED; no toggle bit) every T ms, the first T ms after the boot-up
//! message. A write of 1017h takes effect at once: the next heartbeat is due T ms after the
//! write. Decisions D-HB-n in `docs/decisions.md`.

use crate::abort::Abort;
use crate::context::Outbox;
use crate::frame::Frame;
use crate::nmt::NmtState;
use crate::od::Od;
use crate::time::{Duration, Instant};
use crate::wire::nmt::ErrorControl;

/// Index of the producer heartbeat time.
pub const PRODUCER_TIME: u16 = 0x1017;

/// Heartbeat producer state.
#[derive(Clone, Default)]
pub struct Heartbeat {
    /// Producer time in ms (0 = off).
    period_ms: u16,
    /// When the next heartbeat is due.
    next: Option<Instant>,
}

impl Heartbeat {
    /// The producer time in force, in ms (0: the producer is off).
    pub fn period_ms(&self) -> u16 {
        self.period_ms
    }

    /// Is the heartbeat protocol in use (producer time not 0)? Node guarding is then off
    /// (CiA 301: a node uses one error-control protocol at a time).
    pub fn active(&self) -> bool {
        self.period_ms != 0
    }

    fn period(&self) -> Duration {
        Duration::from_millis(self.period_ms as u64)
    }

    fn start(&mut self, period_ms: u16, now: Instant) {
        self.period_ms = period_ms;
        // Inline, not `now + period` (one call less on an SDO write of 1017h, issue 14's W2);
        // a 16-bit period in microseconds cannot overflow the multiplication.
        let due = now.as_micros().saturating_add(period_ms as u64 * 1000);
        self.next = if period_ms == 0 { None } else { Some(Instant::from_micros(due)) };
    }
}

impl Heartbeat {
    /// Restarts the producer (after boot-up) with the producer time 1017h holds.
    pub fn reset(&mut self, od: &Od, now: Instant) {
        let period = od.value(PRODUCER_TIME, 0).unwrap_or(0) as u16;
        self.start(period, now);
    }

    /// Sends the heartbeat of node `node_id` in state `nmt` when due.
    #[inline]
    pub fn poll(&mut self, out: &mut Outbox, node_id: u8, nmt: NmtState, now: Instant) {
        let Some(due) = self.next else {
            return;
        };
        if now < due {
            return;
        }
        send_error_control(out, node_id, ErrorControl { state: nmt.code(), toggle: false });
        // Keep the period's phase; a shell that polled far too late restarts it instead of
        // sending a burst.
        let period = self.period();
        let next = due + period;
        self.next = Some(if next <= now { now + period } else { next });
    }

    /// When the next heartbeat is due.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.next
    }

    /// Checks a write to 1017h (0 or 10..65535 ms; 1..9 answer 06090030h); on `Ok` the node
    /// stores the value, and the producer restarts with it now. The node then stops life
    /// guarding if the producer runs ([`Heartbeat::active`]).
    pub fn on_write(&mut self, value: u32, now: Instant) -> Result<(), Abort> {
        if (1..10).contains(&value) || value > 0xFFFF {
            return Err(Abort::INVALID_VALUE);
        }
        self.start(value as u16, now);
        Ok(())
    }
}

/// Queues the error-control message `message` on 700h + `node_id`: the heartbeat, the
/// node-guarding answer and the boot-up message, built in one place.
#[inline(never)]
pub(crate) fn send_error_control(out: &mut Outbox, node_id: u8, message: ErrorControl) {
    out.send(Frame::std(0x700 + node_id as u16, &message.emit()));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::context::Output;

    /// No device, no node: the producer alone, with an outbox.
    #[test]
    fn limits_and_timing() {
        let mut hb = Heartbeat::default();
        let mut out = Outbox::default();
        let at = Instant::from_millis;
        for bad in [1, 5, 9, 0x1_0000] {
            assert_eq!(hb.on_write(bad, at(0)), Err(Abort::INVALID_VALUE));
        }
        assert_eq!(hb.period_ms(), 0);
        assert_eq!(hb.next_deadline(), None);
        assert_eq!(hb.on_write(10, at(7)), Ok(()));
        assert_eq!(hb.next_deadline(), Some(at(17)));
        assert_eq!(hb.on_write(0xFFFF, at(7)), Ok(()));
        assert_eq!(hb.next_deadline(), Some(at(7 + 65535)));
        assert_eq!(hb.on_write(100, at(7)), Ok(()));
        hb.poll(&mut out, 3, NmtState::Stopped, at(106));
        assert!(out.is_empty());
        hb.poll(&mut out, 3, NmtState::Stopped, at(107));
        assert_eq!(out.pop(), Some(Output::Frame(Frame::std(0x703, &[0x04]))));
        assert_eq!(hb.next_deadline(), Some(at(207)));
        // A late poll keeps the phase; a very late one restarts the period.
        hb.poll(&mut out, 3, NmtState::Operational, at(250));
        assert_eq!(out.pop(), Some(Output::Frame(Frame::std(0x703, &[0x05]))));
        assert_eq!(hb.next_deadline(), Some(at(307)));
        hb.poll(&mut out, 3, NmtState::PreOperational, at(1000));
        assert_eq!(out.pop(), Some(Output::Frame(Frame::std(0x703, &[0x7F]))));
        assert_eq!(hb.next_deadline(), Some(at(1100)));
        assert_eq!(hb.on_write(0, at(1000)), Ok(()));
        assert_eq!(hb.next_deadline(), None);
        hb.poll(&mut out, 3, NmtState::Operational, at(5000));
        assert!(out.is_empty());
    }
}
