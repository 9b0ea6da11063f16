//! Heartbeat producer (1017h, CiA 301 §7.2.8.3.2.2).
//!
//! With a producer time of T ms (0 = off; 1..9 are refused, as every manual allows only 0 and
//! 10..65535) the node sends 700h + node-ID with its NMT state (05h OPERATIONAL, 7Fh
//! PRE-OPERATIONAL, 04h STOPPED; no toggle bit) every T ms, the first T ms after the boot-up
//! message. A write of 1017h takes effect at once: the next heartbeat is due T ms after the
//! write. Decisions D-HB-n in `docs/decisions.md`.

use crate::abort::Abort;
use crate::frame::Frame;
use crate::guarding;
use crate::node::Core;
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
        self.next = if period_ms == 0 { None } else { Some(now + self.period()) };
    }
}

/// Restarts the producer (after boot-up) with the producer time 1017h holds.
pub fn reset(core: &mut Core, now: Instant) {
    let period = core.od.value(PRODUCER_TIME, 0).unwrap_or(0) as u16;
    core.heartbeat.start(period, now);
}

/// Sends the heartbeat when due.
pub fn poll(core: &mut Core, now: Instant) {
    let Some(due) = core.heartbeat.next else {
        return;
    };
    if now < due {
        return;
    }
    let message = ErrorControl { state: core.nmt.code(), toggle: false };
    core.out.send(Frame::std(0x700 + core.node_id as u16, &message.emit()));
    // Keep the period's phase; a shell that polled far too late restarts it instead of
    // sending a burst.
    let period = core.heartbeat.period();
    let next = due + period;
    core.heartbeat.next = Some(if next <= now { now + period } else { next });
}

/// When the next heartbeat is due.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    core.heartbeat.next
}

/// Checks a write to 1017h (0 or 10..65535 ms; 1..9 answer 06090030h); on `Ok` the node
/// stores the value, and the producer restarts with it now.
pub fn on_write(core: &mut Core, value: u32, now: Instant) -> Result<(), Abort> {
    if (1..10).contains(&value) || value > 0xFFFF {
        return Err(Abort::INVALID_VALUE);
    }
    core.heartbeat.start(value as u16, now);
    if value != 0 {
        guarding::suspend(core);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::Bitrate;
    use crate::devices::sgh10;
    use crate::nmt::NmtState;
    use crate::node::{Device, Node, Output};

    struct T;
    impl Device for T {
        fn table(&self) -> &'static [crate::od::Entry] {
            sgh10::TABLE
        }
    }

    #[test]
    fn limits_and_timing() {
        let mut node = Node::new(T, 3, Bitrate::K500);
        node.poll(Instant::ZERO);
        assert_eq!(node.next_output(), Some(Output::Frame(Frame::std(0x703, &[0]))));
        assert_eq!(node.next_deadline(), None);
        let core = node.split().1;
        for bad in [1, 5, 9, 0x1_0000] {
            assert_eq!(on_write(core, bad, Instant::ZERO), Err(Abort::INVALID_VALUE));
        }
        assert_eq!(core.heartbeat.period_ms(), 0);
        assert_eq!(on_write(core, 10, Instant::from_millis(7)), Ok(()));
        assert_eq!(next_deadline(core), Some(Instant::from_millis(17)));
        assert_eq!(on_write(core, 0xFFFF, Instant::from_millis(7)), Ok(()));
        assert_eq!(next_deadline(core), Some(Instant::from_millis(7 + 65535)));
        assert_eq!(on_write(core, 100, Instant::from_millis(7)), Ok(()));
        core.nmt = NmtState::Stopped;
        node.poll(Instant::from_millis(106));
        assert_eq!(node.next_output(), None);
        node.poll(Instant::from_millis(107));
        assert_eq!(node.next_output(), Some(Output::Frame(Frame::std(0x703, &[0x04]))));
        assert_eq!(node.next_deadline(), Some(Instant::from_millis(207)));
        // A late poll keeps the phase; a very late one restarts the period.
        node.poll(Instant::from_millis(250));
        assert_eq!(node.next_deadline(), Some(Instant::from_millis(307)));
        node.poll(Instant::from_millis(1000));
        assert_eq!(node.next_deadline(), Some(Instant::from_millis(1100)));
        let core = node.split().1;
        assert_eq!(on_write(core, 0, Instant::from_millis(1000)), Ok(()));
        assert_eq!(next_deadline(core), None);
    }
}
