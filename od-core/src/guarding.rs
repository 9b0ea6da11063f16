//! Node guarding and life guarding (100Ch, 100Dh; CiA 301 §7.2.8.3.2.1).
//!
//! The master's remote frame on 700h + node-ID is answered with one byte: the toggle bit (bit
//! 7; 0 in the first answer after boot-up, alternating with every answer) and the NMT state
//! (bits 6..0). The first RTR also starts life guarding when guard time (100Ch, ms) and life
//! time factor (100Dh) are both non-zero: when a life time (their product) passes without an
//! RTR, the node notes a life guarding event ([`Guarding::life_guard_event`]: the WV5800M's red LED
//! double flash) and waits for the next RTR, which ends it. No EMCY and no NMT state change:
//! no manual lists one. While the heartbeat producer runs (1017h not 0) the node uses the
//! heartbeat protocol only and does not answer RTRs (CiA 301). Decisions D-HB-n in
//! `docs/decisions.md`.

use crate::abort::Abort;
use crate::context::Outbox;
use crate::heartbeat::send_error_control;
use crate::nmt::NmtState;
use crate::od::Od;
use crate::time::Instant;
use crate::wire::nmt::ErrorControl;

/// Index of the guard time.
pub const GUARD_TIME: u16 = 0x100C;
/// Index of the life time factor.
pub const LIFE_TIME_FACTOR: u16 = 0x100D;

/// Node/life guarding state.
#[derive(Clone, Default)]
pub struct Guarding {
    /// Toggle bit of the next answer.
    toggle: bool,
    /// 100Ch in ms.
    guard_ms: u16,
    /// 100Dh.
    factor: u8,
    /// When the life time runs out (life guarding started and not expired).
    deadline: Option<Instant>,
    /// A life time passed without an RTR, and no RTR has come since.
    event: bool,
}

impl Guarding {
    /// Life time in ms (0: life guarding off).
    pub fn life_time_ms(&self) -> u32 {
        self.guard_ms as u32 * self.factor as u32
    }

    fn restart(&mut self, now: Instant) {
        let life = self.life_time_ms();
        self.deadline = if life == 0 { None } else { Some(now.add_millis(life as u64)) };
    }
}

impl Guarding {
    /// Has a life guarding event happened and no guarding RTR come since?
    pub fn life_guard_event(&self) -> bool {
        self.event
    }

    /// Restarts guarding (after boot-up) with 100Ch/100Dh from `od`: toggle bit 0, life
    /// guarding off until the first RTR.
    pub fn reset(&mut self, od: &Od) {
        let guard_ms = od.value(GUARD_TIME, 0).unwrap_or(0) as u16;
        let factor = od.value(LIFE_TIME_FACTOR, 0).unwrap_or(0) as u8;
        *self = Guarding { guard_ms, factor, ..Guarding::default() };
    }

    /// Stops life guarding (the heartbeat producer was switched on).
    pub fn suspend(&mut self) {
        self.deadline = None;
    }

    /// Answers a guarding RTR for node `node_id` in state `nmt` and restarts the life time;
    /// nothing while the heartbeat producer runs (`heartbeat_active`). Returns whether a life
    /// guarding event ended.
    pub fn on_rtr(
        &mut self,
        out: &mut Outbox,
        node_id: u8,
        nmt: NmtState,
        heartbeat_active: bool,
        now: Instant,
    ) -> bool {
        if heartbeat_active {
            return false;
        }
        send_error_control(out, node_id, ErrorControl { state: nmt.code(), toggle: self.toggle });
        self.toggle = !self.toggle;
        let ended = core::mem::replace(&mut self.event, false);
        self.restart(now);
        ended
    }

    /// Detects an expired life time; returns true when a life guarding event begins.
    #[inline]
    pub fn poll(&mut self, now: Instant) -> bool {
        match self.deadline {
            Some(deadline) if now >= deadline => {
                self.deadline = None;
                self.event = true;
                true
            }
            _ => false,
        }
    }

    /// When the life time next expires.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.deadline
    }

    /// Checks a write to 100Ch/100Dh (`index`; every value is allowed); on `Ok` the node
    /// stores the value. Running life guarding restarts with the new life time from now; a
    /// life time of 0 stops it.
    pub fn on_write(&mut self, index: u16, value: u32, now: Instant) -> Result<(), Abort> {
        match index {
            GUARD_TIME => self.guard_ms = value as u16,
            LIFE_TIME_FACTOR => self.factor = value as u8,
            _ => return Ok(()),
        }
        if self.deadline.is_some() {
            self.restart(now);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::context::Output;

    /// No device, no node: guarding alone, with an outbox.
    #[test]
    fn toggle_and_life_time() {
        let mut g = Guarding::default();
        let mut out = Outbox::default();
        let at = Instant::from_millis;
        let mut rtr = |g: &mut Guarding, hb: bool, ms: u64| {
            g.on_rtr(&mut out, 1, NmtState::PreOperational, hb, at(ms));
            match out.pop() {
                Some(Output::Frame(f)) => Some(f.data[0]),
                _ => None,
            }
        };
        // Guarding answers even with 100Ch/100Dh at 0; no life guarding then.
        assert_eq!(rtr(&mut g, false, 1), Some(0x7F));
        assert_eq!(rtr(&mut g, false, 2), Some(0xFF));
        assert_eq!(g.next_deadline(), None);
        g.on_write(GUARD_TIME, 100, at(3)).unwrap();
        g.on_write(LIFE_TIME_FACTOR, 3, at(3)).unwrap();
        assert_eq!(g.next_deadline(), None);
        assert_eq!(rtr(&mut g, false, 10), Some(0x7F));
        assert_eq!(g.next_deadline(), Some(at(310)));
        assert!(!g.poll(at(309)) && !g.life_guard_event());
        assert!(g.poll(at(310)) && g.life_guard_event());
        assert_eq!(g.next_deadline(), None);
        assert_eq!(rtr(&mut g, false, 400), Some(0xFF));
        assert!(!g.life_guard_event());
        // A new factor restarts the running life time from the write.
        g.on_write(LIFE_TIME_FACTOR, 5, at(450)).unwrap();
        assert_eq!(g.next_deadline(), Some(at(950)));
        g.on_write(GUARD_TIME, 0, at(460)).unwrap();
        assert_eq!(g.next_deadline(), None);
        // While the heartbeat runs, no answer.
        assert_eq!(rtr(&mut g, true, 500), None);
    }
}
