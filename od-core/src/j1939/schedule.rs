//! Cyclic transmission of process-data groups (manual §5.4; D-J1939-10).
//!
//! Each group has a cycle time in ms (0 switches it off) and a priority, as 3000h holds them
//! for the WV58MR (EPOS 64607 and ESPD 64609 every 50 ms at priority 3, Proprietary B 65450
//! off at priority 6). The [`Scheduler`] only says which group is due and at which priority;
//! the node builds the payload from the dictionary and the identifier from its claimed
//! address. It stays stopped until the address claim has stood ([`Scheduler::start`]).
//!
//! Timing: at the start every enabled group is due at once, then every cycle, each slot on its
//! own grid (a late poll does not shift the grid, a poll more than a cycle late sends once and
//! starts a new grid). A group switched on from 0 is due at once ("sent as soon as a cycle
//! time above 0 is entered", manual §5.4.4); a changed non-zero cycle applies from the last
//! transmission (due at `last + new`, at once if that has passed); 0 stops it.

use crate::time::Instant;
use crate::wire::j1939::{Pgn, Priority};

/// One cyclic group.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Cyclic {
    pgn: Pgn,
    cycle_ms: u16,
    priority: Priority,
    next: Option<Instant>,
}

impl Cyclic {
    /// Group `pgn` every `cycle_ms` (0: off) at `priority`.
    pub const fn new(pgn: Pgn, cycle_ms: u16, priority: Priority) -> Cyclic {
        Cyclic { pgn, cycle_ms, priority, next: None }
    }
}

/// A group that is due: send `pgn` at `priority` now.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Due {
    /// The group.
    pub pgn: Pgn,
    /// Its priority.
    pub priority: Priority,
}

/// The cyclic groups of one node.
#[derive(Clone, Debug)]
pub struct Scheduler<const N: usize> {
    slots: [Cyclic; N],
    running: bool,
}

impl<const N: usize> Scheduler<N> {
    /// A stopped scheduler over `slots`.
    pub const fn new(slots: [Cyclic; N]) -> Scheduler<N> {
        Scheduler { slots, running: false }
    }

    /// Start sending (the claim stood): every enabled group is due at `now`.
    pub fn start(&mut self, now: Instant) {
        self.running = true;
        for s in &mut self.slots {
            s.next = if s.cycle_ms > 0 { Some(now) } else { None };
        }
    }

    /// Stop sending (the address was lost, Cannot Claim, bus-off ...).
    pub fn stop(&mut self) {
        self.running = false;
        for s in &mut self.slots {
            s.next = None;
        }
    }

    /// Is it sending?
    pub const fn is_running(&self) -> bool {
        self.running
    }

    fn slot(&mut self, pgn: Pgn) -> Option<&mut Cyclic> {
        self.slots.iter_mut().find(|s| s.pgn == pgn)
    }

    fn index(&self, pgn: Pgn) -> Option<usize> {
        self.slots.iter().position(|s| s.pgn == pgn)
    }

    /// Set the cycle time of `pgn` (0 switches it off) at `now`; `false` for a group the
    /// scheduler does not have.
    pub fn set_cycle(&mut self, pgn: Pgn, cycle_ms: u16, now: Instant) -> bool {
        match self.index(pgn) {
            Some(k) => {
                self.set_cycle_of(k, cycle_ms, now);
                true
            }
            None => false,
        }
    }

    /// The cycle time and priority of slot `k` (in the order [`Scheduler::new`] took them) as
    /// the dictionary holds them now: a changed cycle time applies as [`Scheduler::set_cycle`]
    /// says, an unchanged one leaves the slot's timing alone. Slots beyond `N` do not exist.
    pub fn configure(&mut self, k: usize, cycle_ms: u16, priority: Priority, now: Instant) {
        if let Some(s) = self.slots.get_mut(k) {
            s.priority = priority;
            if s.cycle_ms != cycle_ms {
                self.set_cycle_of(k, cycle_ms, now);
            }
        }
    }

    fn set_cycle_of(&mut self, k: usize, cycle_ms: u16, now: Instant) {
        let running = self.running;
        let Some(s) = self.slots.get_mut(k) else {
            return;
        };
        let old = s.cycle_ms;
        s.cycle_ms = cycle_ms;
        if !running {
            return;
        }
        s.next = match (s.next, cycle_ms) {
            (_, 0) => None,
            (None, _) => Some(now),
            (Some(next), new) => {
                let last = Instant::from_micros(next.as_micros().saturating_sub(old as u64 * 1000));
                let due = last.add_millis(new as u64);
                Some(if due > now { due } else { now })
            }
        };
    }

    /// Set the priority of `pgn`; `false` for a group the scheduler does not have.
    pub fn set_priority(&mut self, pgn: Pgn, priority: Priority) -> bool {
        match self.slot(pgn) {
            Some(s) => {
                s.priority = priority;
                true
            }
            None => false,
        }
    }

    /// The cycle time and priority of `pgn`.
    pub fn get(&self, pgn: Pgn) -> Option<(u16, Priority)> {
        self.slots.iter().find(|s| s.pgn == pgn).map(|s| (s.cycle_ms, s.priority))
    }

    /// The group due at `now` that has waited longest (slot order on a tie), if any; call
    /// again until `None`.
    pub fn poll(&mut self, now: Instant) -> Option<Due> {
        let mut best: Option<usize> = None;
        for (i, s) in self.slots.iter().enumerate() {
            if let Some(next) = s.next {
                if next <= now && best.is_none_or(|b| self.slots[b].next.is_some_and(|bn| next < bn)) {
                    best = Some(i);
                }
            }
        }
        let s = &mut self.slots[best?];
        let next = s.next?.add_millis(s.cycle_ms as u64);
        s.next = match s.cycle_ms {
            0 => None,
            c => Some(if next > now { next } else { now.add_millis(c as u64) }),
        };
        Some(Due { pgn: s.pgn, priority: s.priority })
    }

    /// When [`Scheduler::poll`] must next run.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.slots.iter().filter_map(|s| s.next).min()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn p(n: u8) -> Priority {
        Priority::new(n).unwrap()
    }

    /// The WV58MR's factory 3000h: Proprietary B off at 6, ESPD and EPOS 50 ms at 3.
    fn wv58mr() -> Scheduler<3> {
        Scheduler::new([
            Cyclic::new(Pgn::PROPRIETARY_B, 0, p(6)),
            Cyclic::new(Pgn::ESPD, 50, p(3)),
            Cyclic::new(Pgn::EPOS, 50, p(3)),
        ])
    }

    fn ms(t: u64) -> Instant {
        Instant::from_millis(t)
    }

    /// Run from `from` to `to` (ms), polling at every deadline; the (ms, pgn) sent.
    fn run(s: &mut Scheduler<3>, from: u64, to: u64) -> Vec<(u64, u32)> {
        let mut out = Vec::new();
        let mut now = ms(from);
        loop {
            while let Some(d) = s.poll(now) {
                out.push((now.as_millis(), d.pgn.raw()));
            }
            match s.next_deadline() {
                Some(t) if t <= ms(to) => now = t,
                _ => return out,
            }
        }
    }

    #[test]
    fn nothing_before_the_start() {
        let mut s = wv58mr();
        assert_eq!(s.poll(ms(1000)), None);
        assert_eq!(s.next_deadline(), None);
        assert!(s.set_cycle(Pgn::PROPRIETARY_B, 10, ms(0)));
        assert_eq!(s.next_deadline(), None);
    }

    #[test]
    fn factory_settings_send_espd_and_epos_every_50_ms() {
        let mut s = wv58mr();
        s.start(ms(250));
        assert_eq!(s.poll(ms(250)), Some(Due { pgn: Pgn::ESPD, priority: p(3) }));
        assert_eq!(s.poll(ms(250)), Some(Due { pgn: Pgn::EPOS, priority: p(3) }));
        assert_eq!(s.poll(ms(250)), None);
        assert_eq!(s.next_deadline(), Some(ms(300)));
        let sent = run(&mut s, 251, 400);
        assert_eq!(sent, [(300, 64609), (300, 64607), (350, 64609), (350, 64607), (400, 64609), (400, 64607)]);
    }

    #[test]
    fn a_cycle_change_applies_from_the_last_transmission_and_zero_stops() {
        let mut s = wv58mr();
        s.start(ms(0));
        run(&mut s, 0, 100); // EPOS/ESPD at 0, 50, 100
                             // E2: EPOS to 100 ms at 120 ms: next at 100 + 100.
        assert!(s.set_cycle(Pgn::EPOS, 100, ms(120)));
        assert_eq!(s.get(Pgn::EPOS), Some((100, p(3))));
        let sent: Vec<_> = run(&mut s, 121, 400).into_iter().filter(|x| x.1 == 64607).collect();
        assert_eq!(sent, [(200, 64607), (300, 64607), (400, 64607)]);
        // Shorter than the time since the last one: due at once.
        assert!(s.set_cycle(Pgn::EPOS, 10, ms(450)));
        assert_eq!(s.poll(ms(450)).map(|d| d.pgn), Some(Pgn::ESPD));
        assert_eq!(s.poll(ms(450)).map(|d| d.pgn), Some(Pgn::EPOS));
        assert_eq!(s.poll(ms(450)), None);
        // Off.
        assert!(s.set_cycle(Pgn::EPOS, 0, ms(455)));
        assert!(run(&mut s, 455, 1000).iter().all(|x| x.1 != 64607));
        assert!(!s.set_cycle(Pgn::EMCY, 5, ms(0)));
    }

    #[test]
    fn proprietary_b_switched_on_is_sent_at_once_at_its_priority() {
        let mut s = wv58mr();
        s.start(ms(0));
        run(&mut s, 0, 10);
        // D4: 3000h.01 := 100 at 30 ms.
        assert!(s.set_cycle(Pgn::PROPRIETARY_B, 100, ms(30)));
        assert_eq!(s.poll(ms(30)), Some(Due { pgn: Pgn::PROPRIETARY_B, priority: p(6) }));
        assert_eq!(s.next_deadline(), Some(ms(50)));
        let sent: Vec<_> = run(&mut s, 31, 330).into_iter().filter(|x| x.1 == 65450).collect();
        assert_eq!(sent, [(130, 65450), (230, 65450), (330, 65450)]);
        // D22: a priority change shows in the next transmission.
        assert!(s.set_priority(Pgn::EPOS, p(2)));
        assert!(!s.set_priority(Pgn::EMCY, p(2)));
        assert_eq!(s.poll(ms(350)).map(|d| (d.pgn, d.priority)), Some((Pgn::ESPD, p(3))));
        assert_eq!(s.poll(ms(350)).map(|d| (d.pgn, d.priority)), Some((Pgn::EPOS, p(2))));
    }

    #[test]
    fn configure_by_slot_changes_the_timing_only_with_the_cycle() {
        let mut s = wv58mr();
        s.start(ms(0));
        run(&mut s, 0, 10);
        // The same cycle time: the grid stays (EPOS next at 50), the priority changes.
        s.configure(2, 50, p(2), ms(20));
        assert_eq!(s.get(Pgn::EPOS), Some((50, p(2))));
        assert_eq!(s.next_deadline(), Some(ms(50)));
        // A new one applies from the last transmission, as set_cycle does.
        s.configure(2, 30, p(2), ms(20));
        assert_eq!(s.next_deadline(), Some(ms(30)));
        // Slot 0 (Proprietary B) switched on: due at once. No slot 3: nothing happens.
        s.configure(0, 100, p(6), ms(25));
        assert_eq!(s.poll(ms(25)).map(|d| d.pgn), Some(Pgn::PROPRIETARY_B));
        s.configure(3, 10, p(1), ms(25));
        assert_eq!((s.get(Pgn::PROPRIETARY_B), s.get(Pgn::ESPD)), (Some((100, p(6))), Some((50, p(3)))));
    }

    #[test]
    fn a_late_poll_keeps_the_grid_a_very_late_one_restarts_it() {
        let mut s = Scheduler::new([Cyclic::new(Pgn::EPOS, 50, p(3))]);
        s.start(ms(0));
        assert!(s.poll(ms(0)).is_some());
        assert!(s.poll(ms(60)).is_some());
        assert_eq!(s.next_deadline(), Some(ms(100)));
        assert!(s.poll(ms(500)).is_some());
        assert_eq!(s.poll(ms(500)), None, "no burst after a stall");
        assert_eq!(s.next_deadline(), Some(ms(550)));
    }

    #[test]
    fn stop_and_restart() {
        let mut s = wv58mr();
        s.start(ms(0));
        s.stop();
        assert!(!s.is_running());
        assert_eq!(s.next_deadline(), None);
        assert_eq!(s.poll(ms(100)), None);
        s.start(ms(200));
        assert_eq!(s.next_deadline(), Some(ms(200)));
        // The longest-waiting group goes first.
        s.set_cycle(Pgn::PROPRIETARY_B, 20, ms(200));
        s.poll(ms(200));
        s.poll(ms(200));
        s.poll(ms(200));
        assert_eq!(s.poll(ms(260)).map(|d| d.pgn), Some(Pgn::PROPRIETARY_B));
    }

    mod properties {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// Whatever the cycle changes, a running group is never sent twice within less than
            /// its cycle time unless its cycle changed in between, and polling never panics.
            #[test]
            fn cycles_are_kept(changes in proptest::collection::vec((0usize..3, 0u16..300, 0u64..400), 0..20)) {
                let mut s = wv58mr();
                s.start(ms(0));
                let pgns = [Pgn::PROPRIETARY_B, Pgn::ESPD, Pgn::EPOS];
                let mut last: [Option<u64>; 3] = [None; 3];
                let mut now = 0u64;
                for (slot, cycle, dt) in changes {
                    let end = now + dt;
                    for (t, pgn) in run(&mut s, now, end) {
                        let i = pgns.iter().position(|p| p.raw() == pgn).unwrap();
                        let c = s.get(pgns[i]).unwrap().0 as u64;
                        prop_assert!(c > 0);
                        if let Some(l) = last[i] { prop_assert!(t >= l + c, "{} at {} after {} cycle {}", pgn, t, l, c); }
                        last[i] = Some(t);
                    }
                    now = end;
                    s.set_cycle(pgns[slot], cycle, ms(now));
                    last[slot] = None;
                }
            }
        }
    }
}
