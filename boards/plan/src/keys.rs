//! The AP10T's four keys, debounced.
//!
//! The board scans the key pins every sample period and hands the levels to
//! [`Debouncer::scan`] as a bit set (bit `k` = key `k` reads pressed). A key's debounced state
//! changes once its raw level has held for [`DEBOUNCE_US`] since it last changed: contact bounce
//! of a tactile key lasts a few milliseconds, and 20 ms is still far below what a person notices
//! between pressing and the display reacting. Each key is debounced on its own, so one bouncing
//! key never delays another. The manual defines no long press or auto-repeat (AP10T digest
//! §2.6), so there is none here; the device sees the debounced levels, as the status word
//! reports them while a key is "actuated".
//!
//! Bit order, as the status word 5F19h reports the keys: bit 0 the front key (SW bit 0), bit 1
//! "←" (SW bit 13), bit 2 "*" (SW bit 14), bit 3 "↑" (SW bit 15).

use od_core::Instant;

/// Keys on the board.
pub const KEYS: usize = 4;

/// How long a level must hold before it counts, in microseconds.
pub const DEBOUNCE_US: u64 = 20_000;

/// The front key (acknowledgement).
pub const FRONT: u8 = 1 << 0;
/// The "←" key.
pub const LEFT: u8 = 1 << 1;
/// The "*" key.
pub const STAR: u8 = 1 << 2;
/// The "↑" key.
pub const UP: u8 = 1 << 3;

/// A change of the debounced keys.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Change {
    /// Keys pressed since the last change.
    pub pressed: u8,
    /// Keys released since the last change.
    pub released: u8,
    /// Every key held down now.
    pub held: u8,
}

/// The debounced state of the four keys.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Debouncer {
    stable: u8,
    raw: u8,
    since: [Instant; KEYS],
}

impl Debouncer {
    /// Every key released (a key held at power-on is reported pressed after [`DEBOUNCE_US`]).
    pub const fn new() -> Debouncer {
        Debouncer { stable: 0, raw: 0, since: [Instant::ZERO; KEYS] }
    }

    /// The keys held down, debounced.
    pub const fn held(&self) -> u8 {
        self.stable
    }

    /// Takes one scan of the raw levels at `now`; returns the change of the debounced keys, if
    /// any.
    pub fn scan(&mut self, raw: u8, now: Instant) -> Option<Change> {
        let raw = raw & ((1 << KEYS) - 1);
        let mut next = self.stable;
        for k in 0..KEYS {
            let bit = 1 << k;
            if (raw ^ self.raw) & bit != 0 {
                self.since[k] = now;
            }
            if (raw ^ self.stable) & bit != 0 && now.micros_since(self.since[k]) >= DEBOUNCE_US {
                next ^= bit;
            }
        }
        self.raw = raw;
        if next == self.stable {
            return None;
        }
        let change = Change { pressed: next & !self.stable, released: self.stable & !next, held: next };
        self.stable = next;
        Some(change)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> Instant {
        Instant::from_millis(t)
    }

    /// Scans `levels` (one per millisecond from `start`) and collects the changes.
    fn run(d: &mut Debouncer, start: u64, levels: &[u8]) -> Vec<(u64, Change)> {
        let mut out = Vec::new();
        for (i, &l) in levels.iter().enumerate() {
            let t = start + i as u64;
            if let Some(c) = d.scan(l, ms(t)) {
                out.push((t, c));
            }
        }
        out
    }

    #[test]
    fn a_bouncing_press_and_release_count_once_each() {
        let mut d = Debouncer::new();
        // Bounce for 4 ms, then held for 30 ms, then a bouncing release.
        let mut levels = vec![0, 1, 0, 1, 0];
        levels.extend([1; 30]);
        levels.extend([0, 1, 0, 1]);
        levels.extend([0; 30]);
        let changes = run(&mut d, 100, &levels);
        assert_eq!(changes.len(), 2, "{changes:?}");
        // Pressed 20 ms after the last bounce edge (t = 105), released likewise (t = 139).
        assert_eq!(changes[0], (125, Change { pressed: FRONT, released: 0, held: FRONT }));
        assert_eq!(changes[1], (159, Change { pressed: 0, released: FRONT, held: 0 }));
    }

    #[test]
    fn a_short_glitch_is_no_press() {
        let mut d = Debouncer::new();
        let mut levels = vec![0; 5];
        levels.extend([STAR; 19]);
        levels.extend([0; 40]);
        assert!(run(&mut d, 0, &levels).is_empty());
        assert_eq!(d.held(), 0);
    }

    #[test]
    fn keys_are_debounced_each_on_its_own() {
        let mut d = Debouncer::new();
        // UP pressed cleanly at t = 0; LEFT bounces from t = 10 to 15.
        let mut levels = vec![UP; 10];
        levels.extend([UP | LEFT, UP, UP | LEFT, UP, UP | LEFT, UP]);
        levels.extend([UP | LEFT; 40]);
        let changes = run(&mut d, 0, &levels);
        assert_eq!(changes[0], (20, Change { pressed: UP, released: 0, held: UP }), "not delayed by LEFT");
        assert_eq!(changes[1], (36, Change { pressed: LEFT, released: 0, held: UP | LEFT }));
        assert_eq!(changes.len(), 2);
    }

    #[test]
    fn held_at_power_on_and_other_pins_ignored() {
        let mut d = Debouncer::new();
        assert_eq!(d.scan(0xF0 | FRONT, ms(0)), None);
        assert_eq!(d.scan(FRONT, ms(19)), None);
        assert_eq!(d.scan(0xF0 | FRONT, ms(20)), Some(Change { pressed: FRONT, released: 0, held: FRONT }));
    }
}
