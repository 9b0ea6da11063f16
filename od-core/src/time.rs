//! Time as the core sees it: an instant the caller passes in, and spans between instants. The
//! core never reads a clock.

use core::ops::{Add, AddAssign, Sub};

/// A point in time, in microseconds since an arbitrary origin (power-on in the firmware,
/// zero in host tests). Only differences matter.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Instant(u64);

impl Instant {
    /// The origin.
    pub const ZERO: Instant = Instant(0);

    /// From microseconds.
    pub const fn from_micros(us: u64) -> Instant {
        Instant(us)
    }

    /// From milliseconds.
    pub const fn from_millis(ms: u64) -> Instant {
        Instant(ms * 1000)
    }

    /// Microseconds since the origin.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Microseconds since the origin modulo `period_us` (0 for 0): the phase of a periodic
    /// pattern such as a blinking LED, without a 64-bit division ([`crate::arith::rem_u64`]).
    #[inline]
    pub const fn phase(self, period_us: u32) -> u32 {
        crate::arith::rem_u64(self.0, period_us)
    }

    /// Whole milliseconds since the origin.
    pub const fn as_millis(self) -> u64 {
        self.0 / 1000
    }

    /// This instant plus `ms` milliseconds.
    pub const fn add_millis(self, ms: u64) -> Instant {
        Instant(self.0.saturating_add(ms * 1000))
    }

    /// This instant plus `us` microseconds.
    pub const fn add_micros(self, us: u64) -> Instant {
        Instant(sat_add(self.0, us))
    }

    /// Microseconds from `earlier` to `self`, zero if `earlier` is later.
    pub const fn micros_since(self, earlier: Instant) -> u64 {
        self.0.saturating_sub(earlier.0)
    }

    /// This instant plus `d` (saturating at the end of time).
    pub const fn add(self, d: Duration) -> Instant {
        Instant(sat_add(self.0, d.0))
    }

    /// The span from `earlier` to `self`, zero if `earlier` is later.
    pub const fn since(self, earlier: Instant) -> Duration {
        Duration(self.0.saturating_sub(earlier.0))
    }
}

/// `a + b`, saturating: one out-of-line copy of the 64-bit carry test for every timer.
#[inline(never)]
const fn sat_add(a: u64, b: u64) -> u64 {
    a.saturating_add(b)
}

/// A span of time in microseconds: a timer period, a delay, a timeout. Unsigned; arithmetic
/// saturates, so no span of bus input can overflow.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Duration(u64);

impl Duration {
    /// No time.
    pub const ZERO: Duration = Duration(0);

    /// From microseconds.
    pub const fn from_micros(us: u64) -> Duration {
        Duration(us)
    }

    /// From milliseconds (saturating).
    pub const fn from_millis(ms: u64) -> Duration {
        Duration(ms.saturating_mul(1000))
    }

    /// From seconds (saturating).
    pub const fn from_secs(s: u64) -> Duration {
        Duration(s.saturating_mul(1_000_000))
    }

    /// In microseconds.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// In whole milliseconds.
    pub const fn as_millis(self) -> u64 {
        self.0 / 1000
    }

    /// Is it zero?
    pub const fn is_zero(self) -> bool {
        self.0 == 0
    }

    /// This span `n` times (saturating).
    pub const fn times(self, n: u64) -> Duration {
        Duration(self.0.saturating_mul(n))
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;
    fn add(self, d: Duration) -> Instant {
        Instant::add(self, d)
    }
}

impl AddAssign<Duration> for Instant {
    fn add_assign(&mut self, d: Duration) {
        *self = Instant::add(*self, d);
    }
}

impl Sub<Instant> for Instant {
    type Output = Duration;
    /// The span between two instants, zero if the right one is later.
    fn sub(self, earlier: Instant) -> Duration {
        self.since(earlier)
    }
}

impl Add for Duration {
    type Output = Duration;
    fn add(self, d: Duration) -> Duration {
        Duration(sat_add(self.0, d.0))
    }
}

/// The earlier of two optional deadlines.
pub fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if x <= y { x } else { y }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// The next deadline a node's poll left, remembered until anything else touches the node
/// (D-ARCH-5): a poll before it has nothing to do. Every call that changes the node but its
/// poll [`Due::forget`]s it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Due(Option<Option<Instant>>);

impl Due {
    /// Something touched the node: the next deadline is computed afresh.
    #[inline]
    pub fn forget(&mut self) {
        self.0 = None;
    }

    /// Remembers the deadline a poll has just left.
    #[inline]
    pub fn remember(&mut self, deadline: Option<Instant>) {
        self.0 = Some(deadline);
    }

    /// Is nothing due at `now` (a remembered deadline, later than `now` or none)?
    #[inline]
    pub fn nothing_at(&self, now: Instant) -> bool {
        matches!(self.0, Some(due) if due.is_none_or(|d| now < d))
    }

    /// The remembered deadline, else `compute`'s.
    #[inline]
    pub fn get(&self, compute: impl FnOnce() -> Option<Instant>) -> Option<Instant> {
        self.0.unwrap_or_else(compute)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_is_the_64_bit_remainder() {
        let mut x = 0x1234_5678_9ABC_DEF0u64;
        for _ in 0..50_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            for p in [1u32, 7, 1000, 100_000, 1_600_000, (1 << 21) - 1, (x >> 43) as u32 | 1] {
                let t = Instant::from_micros(x);
                assert_eq!(t.phase(p) as u64, x % p as u64, "{x} % {p}");
            }
        }
        assert_eq!(Instant::from_micros(u64::MAX).phase(1_000_000) as u64, u64::MAX % 1_000_000);
    }

    #[test]
    fn durations_add_to_instants_and_saturate() {
        let t = Instant::from_millis(5);
        assert_eq!(t + Duration::from_millis(10), Instant::from_millis(15));
        assert_eq!(Instant::from_millis(15) - t, Duration::from_millis(10));
        assert_eq!(t - Instant::from_millis(15), Duration::ZERO);
        assert_eq!(Instant::from_micros(u64::MAX - 1) + Duration::from_secs(1), Instant::from_micros(u64::MAX));
        assert_eq!(Duration::from_millis(u64::MAX), Duration::from_micros(u64::MAX));
        assert_eq!(Duration::from_millis(3).times(4), Duration::from_millis(12));
        assert_eq!(Duration::from_micros(2500).as_millis(), 2);
        let mut u = t;
        u += Duration::from_micros(1);
        assert_eq!(u.since(t), Duration::from_micros(1));
    }
}
