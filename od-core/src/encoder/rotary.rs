//! The rotary multiturn encoder (WV5800M / WH5800M): the position pipeline from the sensor's
//! raw count to the position value, as pure functions.
//!
//! # The position pipeline
//!
//! The sensor counts [`PHYSICAL_STEPS`] steps per revolution over `N` revolutions (6501h,
//! 6502h): the raw value 600Ch runs `0 .. R` with `R = 16384 × N` and wraps after `N` turns.
//! From it ([`Scaling`]):
//!
//! 1. counting direction (6000h bit 0): `directed = raw` (sense of rotation I, ascending
//!    clockwise, the sensor's own sense) or `(R − raw) mod R` (sense E, ascending
//!    counter-clockwise);
//! 2. calibration: `counts = (directed − c) mod R`, where `c` (6509h "encoder state at the time
//!    of calibration") is the directed raw count captured when 1h was written to 2002h, so the
//!    measured value is "zeroed" there;
//! 3. scaling (6001h = APU, always on): `measured = counts × APU / 16384`, truncated, so the
//!    measured value runs `0 .. T` with `T = APU × N` (6002h) and wraps exactly where the raw
//!    count wraps;
//! 4. `position = (measured + 6003h + 2001h) mod T` (6004h), the manual's "position value =
//!    measured value + calibration value + application offset", kept in `0 .. T` (650Ah.02/.03).
//!
//! Because `c` is a raw count, changing the APU keeps the calibration point: the position read
//! there is still `6003h + 2001h`. A change of the counting direction maps `c` to
//! `(R − c) mod R` ([`Scaling::with_direction`]), which is the directed count of the same shaft
//! angle, so the calibration point keeps its value too and every other position now counts the
//! other way from it.
//!
//! The speed (6030h.01) is the raw count's change in increments per millisecond
//! ([`speed_value`]), its sign following the counting direction.
//!
//! The decisions are in `docs/decisions.md`, "WV5800M".

use crate::encoder::Window;
use crate::od::{Access::*, DataType::*, Entry, Group, Hook};

/// Physical measuring steps per revolution (6501h).
pub const PHYSICAL_STEPS: u32 = 16_384;

/// 6000h bit 0: sense of rotation E (ascending counter-clockwise).
pub const DIRECTION_BIT: u16 = 1 << 0;
/// 6000h bit 2: scaling enabled (always set).
pub const SCALING_BIT: u16 = 1 << 2;

/// Largest APU (6001h).
pub const MAX_APU: u32 = 65_535;

/// The maximum speed in raw increments per second: 6000 rpm, the speed the manual's conversion
/// formula quotes (6000 rpm = 1638.4 Inc/ms).
pub const MAX_SPEED_INC_PER_S: u64 = 1_638_400;

/// The raw range `R` of an encoder with `revolutions` distinguishable revolutions.
pub const fn raw_range(revolutions: u32) -> u32 {
    PHYSICAL_STEPS * revolutions
}

/// How many entries [`status_rows`] declares.
pub const STATUS_ROWS: usize = 26;

/// The CiA 406 rotary encoder's work-area, status and identification rows (6400h-650Eh), as the
/// WV5800M and the WV58MR declare them alike for `revolutions` turns: the work-area limits
/// (`0 ..= APU x revolutions - 1`, checked further by the device hook `in_range`), 6500h-6509h,
/// 650Ah with the raw range, the factory serial 650Bh, 650Dh and 650Eh. 6507h is the printed
/// 01000302h (WV58MR A8).
pub const fn status_rows(revolutions: u32, in_range: Hook) -> [Entry; STATUS_ROWS] {
    let n = revolutions as i64;
    let r = PHYSICAL_STEPS as i64 * n;
    let max_pos = MAX_APU as i64 * n - 1;
    [
        Entry::array(0x6400, "Area state register", 2, Ro),
        Entry::member(0x6400, 1, "Work area state channel 1", Unsigned8, Ro, 0),
        Entry::member(0x6400, 2, "Work area state channel 2", Unsigned8, Ro, 0),
        Entry::array(0x6401, "Work area low limit", 2, Ro),
        Entry::member(0x6401, 1, "Work area low limit channel 1", Integer32, Rw, 0)
            .range(0, max_pos)
            .group(Group::App)
            .hook(in_range),
        Entry::member(0x6401, 2, "Work area low limit channel 2", Integer32, Rw, 0)
            .range(0, max_pos)
            .group(Group::App)
            .hook(in_range),
        Entry::array(0x6402, "Work area high limit", 2, Ro),
        Entry::member(0x6402, 1, "Work area high limit channel 1", Integer32, Rw, 0)
            .range(0, max_pos)
            .group(Group::App)
            .hook(in_range),
        Entry::member(0x6402, 2, "Work area high limit channel 2", Integer32, Rw, 0)
            .range(0, max_pos)
            .group(Group::App)
            .hook(in_range),
        Entry::var(0x6500, "Operating status", Unsigned16, Ro, SCALING_BIT as u32),
        Entry::var(0x6501, "Single-turn resolution", Unsigned32, Ro, PHYSICAL_STEPS),
        Entry::var(0x6502, "Number of distinguishable revolutions", Unsigned16, Ro, n as u32),
        Entry::var(0x6503, "Alarms", Unsigned16, Ro, 0),
        Entry::var(0x6504, "Supported alarms", Unsigned16, Ro, 0x3001),
        Entry::var(0x6505, "Warnings", Unsigned16, Ro, 0),
        Entry::var(0x6506, "Supported warnings", Unsigned16, Ro, 0x0001),
        Entry::var(0x6507, "Profile and software version", Unsigned32, Ro, 0x0100_0302),
        Entry::var(0x6508, "Operating time", Unsigned32, Ro, 0xFFFF_FFFF),
        Entry::var(0x6509, "Offset value", Integer32, Ro, 0).group(Group::App),
        Entry::array(0x650A, "Module identification", 3, Ro),
        Entry::member(0x650A, 1, "Manufacturer offset value", Integer32, Ro, 0),
        Entry::member(0x650A, 2, "Manufacturer minimum position value", Integer32, Ro, 0),
        Entry::member(0x650A, 3, "Manufacturer maximum position value", Integer32, Ro, (r - 1) as u32),
        Entry::var(0x650B, "Serial number", Unsigned32, Ro, 0).group(Group::Factory),
        Entry::var(0x650D, "Absolute accuracy", Unsigned8, Ro, 0x08),
        Entry::var(0x650E, "Device functionality", Unsigned32, Ro, 0x0000_0002),
    ]
}

/// Everything the position depends on besides the raw count, as the dictionary holds it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Scaling {
    /// Number of distinguishable revolutions `N` (6502h): 1, 16, 256 or 4096.
    pub revolutions: u32,
    /// Measuring steps per revolution (6001h), 1..=65535.
    pub apu: u32,
    /// Sense of rotation E (6000h bit 0).
    pub ccw: bool,
    /// Directed raw count at the last calibration (6509h), `0 .. R`.
    pub calibration: u32,
    /// Calibration value (6003h).
    pub preset: i32,
    /// Application offset (2001h).
    pub offset: i32,
}

impl Scaling {
    /// The raw range `R = 16384 × N`.
    pub const fn raw_range(&self) -> u32 {
        raw_range(self.revolutions)
    }

    /// The total measuring range `T = APU × N` (6002h).
    pub const fn total(&self) -> u32 {
        self.apu * self.revolutions
    }

    /// Is `raw` a count the sensor can give (`0 .. R`)?
    pub const fn valid(&self, raw: u32) -> bool {
        raw < self.raw_range()
    }

    /// The raw count in the counting direction.
    pub const fn directed(&self, raw: u32) -> u32 {
        let r = self.raw_range();
        let raw = raw % r;
        if self.ccw {
            (r - raw) % r
        } else {
            raw
        }
    }

    /// Raw counts scaled to measuring steps: `counts × APU / 16384`, truncated.
    pub const fn scale(&self, counts: u32) -> u32 {
        (counts as u64 * self.apu as u64 / PHYSICAL_STEPS as u64) as u32
    }

    /// The measured value of `raw`: scaled, directed counts from the calibration point.
    pub const fn measured(&self, raw: u32) -> u32 {
        let r = self.raw_range();
        // Both counts lie in 0 .. R (the calibration reduced, should it not): one wrap at most.
        let (counts, cal) = (self.directed(raw), self.calibration % r);
        self.scale(if counts >= cal { counts - cal } else { counts + (r - cal) })
    }

    /// The position value (6004h) of `raw`.
    pub const fn position(&self, raw: u32) -> u32 {
        let t = self.total();
        // Each term reduced into 0 .. T (T < 2^28), so their sum stays within 32 bits.
        let preset = wrap(self.preset, t);
        let offset = wrap(self.offset, t);
        (self.measured(raw) % t + preset + offset) % t
    }

    /// The calibration (6509h) that zeroes the measured value at `raw` (2002h := 1).
    pub const fn calibrated_at(&self, raw: u32) -> u32 {
        self.directed(raw)
    }

    /// The same scaling with the counting direction `ccw`: the calibration is mapped to the
    /// directed count of the same shaft angle, so the calibration point keeps its position.
    pub const fn with_direction(mut self, ccw: bool) -> Scaling {
        if ccw != self.ccw {
            let r = self.raw_range();
            self.calibration = (r - self.calibration % r) % r;
            self.ccw = ccw;
        }
        self
    }

    /// The largest transferable position value (650Ah.03): `T − 1`.
    pub const fn largest(&self) -> u32 {
        self.total() - 1
    }
}

/// `x` modulo `m` in `0 .. m` (0 for `m == 0`): the Euclidean remainder of a 32-bit value,
/// [`crate::arith::rem_euclid`] without its 64-bit operand. The scaling's signed parameters
/// (6003h, 2001h, 6509h) are 32-bit.
#[inline(never)]
pub const fn wrap(x: i32, m: u32) -> u32 {
    if m == 0 {
        return 0;
    }
    let r = x.unsigned_abs() % m;
    if x < 0 && r != 0 {
        m - r
    } else {
        r
    }
}

/// The signed raw movement from `old` to `new` (600Ch values) on the wrapping raw circle of
/// `raw_range` counts, in the counting direction.
///
/// [`crate::encoder::shortest_delta`] of the two counts in 32 bits: both reduced onto the circle, their
/// difference modulo `raw_range` without a wrap, then the shorter way round.
pub const fn raw_delta(new: u32, old: u32, raw_range: u32, ccw: bool) -> i64 {
    let m = raw_range;
    let d = if m == 0 {
        new as i64 - old as i64
    } else {
        let (a, b) = (new % m, old % m);
        let r = if a >= b { a - b } else { a + (m - b) };
        if r > (m - 1) / 2 {
            r as i64 - m as i64
        } else {
            r as i64
        }
    };
    if ccw {
        -d
    } else {
        d
    }
}

/// The speed value (6030h.01) of a window of raw movement: increments per millisecond times
/// the 6031h multiplier over the divisor, rounded to nearest. Not saturated.
///
/// [`Window::rate`]`(multiplier, 1000 × divisor)` in 64 bits ([`Window::ratio`]): `delta ×
/// mul × 10^6 / (elapsed × 1000 × div)` is `delta × mul × 1000 / (elapsed × div)`. Exact while
/// `|delta| × multiplier` stays below 2^54: a window's raw travel is at most half the raw
/// range (2^25) per sample, and 6031h.03 is 1.
pub fn speed_value(window: Window, multiplier: u32, divisor: u32) -> i64 {
    window.ratio(multiplier, 1000, divisor)
}

/// Is the raw movement of `window` faster than the maximum speed (6000 rpm)?
///
/// `|delta| × 10^6 > 1,638,400 × elapsed`, that is `|delta| × 625 > elapsed × 1024`, in 64
/// bits: with `|delta| = 1024 q + r` (`r < 1024`) the right side is below the left exactly when
/// `elapsed < 625 q + ⌈625 r / 1024⌉`, a sum below 2^64 for every `delta`.
pub fn over_speed(window: Window) -> bool {
    let a = window.delta.unsigned_abs();
    window.elapsed_us < (a >> 10) * 625 + ((a as u32 & 1023) * 625 + 1023) as u64 / 1024
}

/// The speed conditions of the 2003h/2004h limit speeds (in 6030h.01 units): `(low, high)` is
/// (speed below 2003h, speed above 2004h). A limit of 0 is switched off (both ship as 0).
pub const fn limit_speed(speed: i64, low: i16, high: i16) -> (bool, bool) {
    (low != 0 && speed < low as i64, high != 0 && speed > high as i64)
}

/// The 6400h state of a work area with limits `low`/`high` (6401h/6402h) at `position`: the
/// shared inclusive rule ([`crate::encoder::area_state`]); a work area whose limits are both 0
/// (as shipped) is switched off and reads 0.
pub const fn work_area_state(position: u32, low: i32, high: i32) -> u8 {
    if low == 0 && high == 0 {
        0
    } else {
        crate::encoder::area_state(position as i64, low as i64, high as i64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encoder::shortest_delta;
    use proptest::prelude::*;

    const REVS: [u32; 4] = [1, 16, 256, 4096];

    fn scaling(revolutions: u32) -> Scaling {
        Scaling { revolutions, apu: PHYSICAL_STEPS, ccw: false, calibration: 0, preset: 0, offset: 0 }
    }

    #[test]
    fn speed_equals_the_128_bit_rate() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..100_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let mul = [1, 2, 65_535, (x >> 48) as u32][(x % 4) as usize];
            let limit = (1u64 << 54) / mul.max(1) as u64;
            let delta = ((x >> 7) % (2 * limit + 1)) as i64 - limit as i64;
            let elapsed_us = [100_000, 101_000, 1, (x >> 24) + 1, u64::MAX / 65_536][((x >> 3) % 5) as usize];
            let div = [1, 0, 7, 65_535][((x >> 5) % 4) as usize];
            let w = Window { delta, elapsed_us };
            assert_eq!(speed_value(w, mul, div), w.rate(mul as i64, 1000 * div.max(1) as i64), "{w:?} {mul} {div}");
        }
    }

    #[test]
    fn defaults_give_the_raw_count() {
        for n in REVS {
            let s = scaling(n);
            assert_eq!(s.total(), 16384 * n);
            assert_eq!(s.position(0), 0);
            assert_eq!(s.position(s.raw_range() - 1), s.raw_range() - 1);
            assert_eq!(s.largest(), [16383, 262143, 4194303, 67108863][REVS.iter().position(|&r| r == n).unwrap()]);
        }
        // 650Ah.03 at the largest APU, as the manual prints it.
        let s = Scaling { apu: MAX_APU, ..scaling(4096) };
        assert_eq!(s.largest(), 268_431_359);
        let s = Scaling { apu: MAX_APU, ..scaling(1) };
        assert_eq!(s.largest(), 65534);
    }

    #[test]
    fn calibration_sets_preset_plus_offset() {
        let s = Scaling { preset: 510, offset: -10, ..scaling(16) };
        let s = Scaling { calibration: s.calibrated_at(1000), ..s };
        assert_eq!(s.position(1000), 500);
        assert_eq!(s.position(1010), 510);
        // Below the calibration point the value wraps to the top of the range.
        let s = Scaling { preset: 0, offset: 0, ..s };
        assert_eq!(s.position(999), 262_143);
    }

    #[test]
    fn direction_keeps_the_calibration_point() {
        let s = Scaling { preset: 100, ..scaling(1) };
        let s = Scaling { calibration: s.calibrated_at(4000), ..s };
        let e = s.with_direction(true);
        assert_eq!(e.position(4000), 100);
        assert_eq!(s.position(4010), 110);
        assert_eq!(e.position(4010), 90);
        assert_eq!(e.with_direction(false), s);
    }

    #[test]
    fn speed_and_limits() {
        // 16384 increments in 100 ms: 163.84 Inc/ms → 164; 600 rpm.
        let w = Window { delta: 16384, elapsed_us: 100_000 };
        assert_eq!(speed_value(w, 1, 1), 164);
        assert!(!over_speed(w));
        assert!(!over_speed(Window { delta: 163_840, elapsed_us: 100_000 }));
        assert!(over_speed(Window { delta: -163_841, elapsed_us: 100_000 }));
        assert_eq!(raw_delta(2, 262_142, 262_144, false), 4);
        assert_eq!(raw_delta(2, 262_142, 262_144, true), -4);
        assert_eq!(limit_speed(5, 0, 0), (false, false));
        assert_eq!(limit_speed(-5, -4, 0), (true, false));
        assert_eq!(limit_speed(5, -4, 4), (false, true));
        assert_eq!(limit_speed(4, -4, 4), (false, false));
    }

    #[test]
    fn work_areas_switched_off_at_zero() {
        assert_eq!(work_area_state(5, 0, 0), 0);
        assert_eq!(work_area_state(0, 0, 0), 0);
        assert_eq!(work_area_state(5, 0, 4), 0b011);
        assert_eq!(work_area_state(5, 6, 10), 0b101);
        assert_eq!(work_area_state(10, 6, 10), 0);
    }

    fn any_scaling() -> impl Strategy<Value = Scaling> {
        (0usize..4, 1u32..=MAX_APU, any::<bool>(), any::<u32>(), any::<u32>(), any::<i32>()).prop_map(
            |(k, apu, ccw, c, p, o)| {
                let n = REVS[k];
                let r = raw_range(n);
                let t = apu * n;
                Scaling {
                    revolutions: n,
                    apu,
                    ccw,
                    calibration: c % r,
                    preset: (p % t) as i32,
                    // 2001h: ±R as the manual prints it.
                    offset: o.rem_euclid(2 * r as i32) - r as i32,
                }
            },
        )
    }

    proptest! {
        #[test]
        fn wrap_is_the_euclidean_remainder(x in any::<i32>(), m in any::<u32>()) {
            prop_assert_eq!(wrap(x, m), crate::arith::rem_euclid(x as i64, m));
            prop_assert_eq!(wrap(x, m % 70_000), crate::arith::rem_euclid(x as i64, m % 70_000));
            prop_assert_eq!(wrap(i32::MIN + (m % 3) as i32, m), crate::arith::rem_euclid(i32::MIN as i64 + (m % 3) as i64, m));
        }

        #[test]
        fn over_speed_is_the_128_bit_comparison(delta in any::<i64>(), elapsed in any::<u64>(), k in 0usize..4) {
            // Any window, and windows near the limit (1638.4 increments per millisecond).
            let (delta, elapsed) = match k {
                0 => (delta, elapsed),
                1 => (delta >> (elapsed % 64), elapsed >> (delta as u64 % 64)),
                2 => ((elapsed >> 20) as i64 * 16_384 / 10 + delta % 3, elapsed >> 20),
                _ => (delta, (delta.unsigned_abs() as u128 * 625 / 1024) as u64 + elapsed % 3),
            };
            let w = Window { delta, elapsed_us: elapsed };
            let wide = delta.unsigned_abs() as u128 * 1_000_000 > MAX_SPEED_INC_PER_S as u128 * elapsed as u128;
            prop_assert_eq!(over_speed(w), wide, "{:?}", w);
        }

        #[test]
        fn raw_delta_is_the_shortest_delta(new in any::<u32>(), old in any::<u32>(), m in any::<u32>(), k in 0usize..6, ccw in any::<bool>()) {
            // Any modulus, the four raw ranges and no wrap (0), with counts on and off the circle.
            let m = [m, raw_range(1), raw_range(16), raw_range(256), raw_range(4096), 0][k];
            let d = shortest_delta(new as i64, old as i64, m);
            prop_assert_eq!(raw_delta(new, old, m, ccw), if ccw { -d } else { d });
            if m != 0 {
                prop_assert_eq!(raw_delta(new % m, old % m, m, ccw), if ccw { -d } else { d });
            }
        }

        #[test]
        fn position_stays_in_range(s in any_scaling(), raw in any::<u32>()) {
            let raw = raw % s.raw_range();
            prop_assert!(s.position(raw) < s.total());
            prop_assert!(s.measured(raw) < s.total());
        }

        #[test]
        fn preset_round_trip(s in any_scaling(), raw in any::<u32>()) {
            // Writing 6003h and then 2002h := 1 reads back 6003h + 2001h, whatever came before.
            let raw = raw % s.raw_range();
            let c = Scaling { calibration: s.calibrated_at(raw), ..s };
            let t = s.total() as i64;
            prop_assert_eq!(c.position(raw) as i64, (s.preset as i64 + s.offset as i64).rem_euclid(t));
            prop_assert_eq!(c.measured(raw), 0);
        }

        #[test]
        fn scaling_is_monotone_and_exact_per_revolution(s in any_scaling(), raw in any::<u32>()) {
            let s = Scaling { ccw: false, calibration: 0, preset: 0, offset: 0, ..s };
            let r = s.raw_range();
            let raw = raw % r;
            // One revolution further (mod R) is exactly APU steps further (mod T).
            let next = (raw + PHYSICAL_STEPS) % r;
            prop_assert_eq!(s.position(next), (s.position(raw) + s.apu) % s.total());
            if raw + 1 < r {
                let d = s.position(raw + 1) - s.position(raw);
                prop_assert!(d as u64 <= s.apu.div_ceil(PHYSICAL_STEPS) as u64);
            }
        }

        #[test]
        fn wrap_around_has_no_gap(s in any_scaling(), raw in any::<u32>()) {
            // One count further in the counting direction is floor(APU/16384) or
            // ceil(APU/16384) steps further modulo T everywhere: across the physical wrap of
            // the raw count and across the calibration point (where T-1 turns into 0) alike.
            let r = s.raw_range();
            let undirect = |d: u32| if s.ccw { (r - d % r) % r } else { d % r };
            let lo = s.apu / PHYSICAL_STEPS;
            let hi = s.apu.div_ceil(PHYSICAL_STEPS);
            let t = s.total() as i64;
            for d in [s.directed(raw % r), r - 1, s.calibration + r - 1, 0] {
                let d = d % r;
                let here = undirect(d);
                let next = undirect(d + 1);
                let step = (s.position(next) as i64 - s.position(here) as i64).rem_euclid(t) as u32;
                prop_assert!(step == lo || step == hi, "step {} at directed {}", step, d);
            }
            // The measured value turns from T-1 (or the last step below T) to 0 at the
            // calibration point.
            let at = undirect(s.calibration);
            prop_assert_eq!(s.measured(at), 0);
            prop_assert_eq!(s.measured(undirect(s.calibration + r - 1)), s.scale(r - 1));
        }

        #[test]
        fn direction_change_mirrors_about_the_calibration_point(s in any_scaling(), raw in any::<u32>(), d in 0u32..16384) {
            let r = s.raw_range();
            let raw = raw % r;
            let cal = Scaling { calibration: s.calibrated_at(raw), ..s };
            let flipped = cal.with_direction(!s.ccw);
            // The calibration point keeps its value.
            prop_assert_eq!(flipped.position(raw), cal.position(raw));
            // Turning the shaft d counts one way moves the two senses oppositely.
            let moved = (raw + d) % r;
            let t = s.total() as i64;
            let a = (cal.position(moved) as i64 - cal.position(raw) as i64).rem_euclid(t);
            let b = (flipped.position(raw) as i64 - flipped.position(moved) as i64).rem_euclid(t);
            // Truncation may differ by one step between the two senses.
            prop_assert!((a - b).abs() <= 1 || (a - b).abs() >= t - 1, "a={} b={}", a, b);
            // Flipping twice is the identity.
            prop_assert_eq!(flipped.with_direction(s.ccw), cal);
        }

        #[test]
        fn speed_follows_the_direction(old in any::<u32>(), d in -8000i64..8000, k in 0usize..4) {
            let r = raw_range(REVS[k]);
            let old = old % r;
            let new = (old as i64 + d).rem_euclid(r as i64) as u32;
            let expect = if r as i64 > 2 * d.abs() { d } else { shortest_delta(new as i64, old as i64, r) };
            prop_assert_eq!(raw_delta(new, old, r, false), expect);
            prop_assert_eq!(raw_delta(new, old, r, true), -expect);
        }
    }
}
