//! Node guarding and life guarding (100Ch, 100Dh; CiA 301 §7.2.8.3.2.1).
//!
//! The master's remote frame on 700h + node-ID is answered with one byte: the toggle bit (bit
//! 7; 0 in the first answer after boot-up, alternating with every answer) and the NMT state
//! (bits 6..0). The first RTR also starts life guarding when guard time (100Ch, ms) and life
//! time factor (100Dh) are both non-zero: when a life time (their product) passes without an
//! RTR, the node notes a life guarding event ([`life_guard_event`]: the WV5800M's red LED
//! double flash) and waits for the next RTR, which ends it. No EMCY and no NMT state change:
//! no manual lists one. While the heartbeat producer runs (1017h not 0) the node uses the
//! heartbeat protocol only and does not answer RTRs (CiA 301). Decisions D-HB-n in
//! `docs/decisions.md`.

use crate::abort::Abort;
use crate::frame::Frame;
use crate::node::Core;
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

/// Has a life guarding event happened and no guarding RTR come since?
pub fn life_guard_event(core: &Core) -> bool {
    core.guarding.event
}

/// Restarts guarding (after boot-up): toggle bit 0, life guarding off until the first RTR.
pub fn reset(core: &mut Core) {
    let guard_ms = core.od.value(GUARD_TIME, 0).unwrap_or(0) as u16;
    let factor = core.od.value(LIFE_TIME_FACTOR, 0).unwrap_or(0) as u8;
    core.guarding = Guarding { guard_ms, factor, ..Guarding::default() };
}

/// Stops life guarding (the heartbeat producer was switched on).
pub(crate) fn suspend(core: &mut Core) {
    core.guarding.deadline = None;
}

/// Answers a guarding RTR on 700h + node-ID (any DLC) and restarts the life time.
pub fn on_rtr(core: &mut Core, frame: &Frame, now: Instant) {
    if !frame.rtr || core.heartbeat.active() {
        return;
    }
    let message = ErrorControl { state: core.nmt.code(), toggle: core.guarding.toggle };
    core.out.send(Frame::std(0x700 + core.node_id as u16, &message.emit()));
    let g = &mut core.guarding;
    g.toggle = !g.toggle;
    g.event = false;
    g.restart(now);
}

/// Detects an expired life time.
pub fn poll(core: &mut Core, now: Instant) {
    if let Some(deadline) = core.guarding.deadline {
        if now >= deadline {
            core.guarding.deadline = None;
            core.guarding.event = true;
        }
    }
}

/// When the life time next expires.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    core.guarding.deadline
}

/// Checks a write to 100Ch/100Dh (entry `pos`; every value is allowed); on `Ok` the node
/// stores the value. Running life guarding restarts with the new life time from now; a life
/// time of 0 stops it.
pub fn on_write(core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
    let g = &mut core.guarding;
    match core.od.entry(pos).index {
        GUARD_TIME => g.guard_ms = value as u16,
        LIFE_TIME_FACTOR => g.factor = value as u8,
        _ => return Ok(()),
    }
    if g.deadline.is_some() {
        g.restart(now);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::Bitrate;
    use crate::devices::sgh10;
    use crate::frame::CanId;
    use crate::heartbeat;
    use crate::nmt::NmtState;
    use crate::node::{Device, Node, Output};

    struct T;
    impl Device for T {
        fn table(&self) -> &'static [crate::od::Entry] {
            sgh10::TABLE
        }
    }

    fn rtr(node: &mut Node<T>, ms: u64) -> Option<u8> {
        node.on_frame(&Frame::remote(CanId::Std(0x701), 1), Instant::from_millis(ms));
        match node.next_output() {
            Some(Output::Frame(f)) => Some(f.data[0]),
            _ => None,
        }
    }

    fn write(node: &mut Node<T>, index: u16, value: u32, ms: u64) {
        let core = node.split().1;
        let pos = core.od.pos(index, 0).unwrap();
        on_write(core, pos, value, Instant::from_millis(ms)).unwrap();
        core.od.set(pos, value);
    }

    #[test]
    fn toggle_and_life_time() {
        let mut node = Node::new(T, 1, Bitrate::K500);
        node.poll(Instant::ZERO);
        node.next_output();
        // Guarding answers even with 100Ch/100Dh at 0; no life guarding then.
        assert_eq!(rtr(&mut node, 1), Some(0x7F));
        assert_eq!(rtr(&mut node, 2), Some(0xFF));
        assert_eq!(node.next_deadline(), None);
        write(&mut node, GUARD_TIME, 100, 3);
        write(&mut node, LIFE_TIME_FACTOR, 3, 3);
        assert_eq!(node.next_deadline(), None);
        assert_eq!(rtr(&mut node, 10), Some(0x7F));
        assert_eq!(node.next_deadline(), Some(Instant::from_millis(310)));
        node.poll(Instant::from_millis(309));
        assert!(!life_guard_event(node.core()));
        node.poll(Instant::from_millis(310));
        assert!(life_guard_event(node.core()));
        assert_eq!(node.nmt_state(), NmtState::PreOperational);
        assert_eq!(node.next_output(), None);
        assert_eq!(node.next_deadline(), None);
        assert_eq!(rtr(&mut node, 400), Some(0xFF));
        assert!(!life_guard_event(node.core()));
        // A new factor restarts the running life time from the write.
        write(&mut node, LIFE_TIME_FACTOR, 5, 450);
        assert_eq!(node.next_deadline(), Some(Instant::from_millis(950)));
        write(&mut node, GUARD_TIME, 0, 460);
        assert_eq!(node.next_deadline(), None);
    }

    #[test]
    fn heartbeat_excludes_guarding() {
        let mut node = Node::new(T, 1, Bitrate::K500);
        node.poll(Instant::ZERO);
        node.next_output();
        write(&mut node, GUARD_TIME, 100, 0);
        write(&mut node, LIFE_TIME_FACTOR, 2, 0);
        assert_eq!(rtr(&mut node, 0), Some(0x7F));
        heartbeat::on_write(node.split().1, 1000, Instant::from_millis(5)).unwrap();
        assert_eq!(next_deadline(node.core()), None);
        assert_eq!(rtr(&mut node, 10), None);
        heartbeat::on_write(node.split().1, 0, Instant::from_millis(20)).unwrap();
        assert_eq!(rtr(&mut node, 30), Some(0xFF));
    }
}
