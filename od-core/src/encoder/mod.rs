//! The CiA 406 encoder profile, written once and parameterised per device.
//!
//! A device feeds each raw sensor reading to [`Encoder::on_sample`]; the profile turns it into
//! the position value (counting direction, scaling, calibration), the speed, the work-area
//! states, the alarms and warnings, and raises and clears the manufacturer EMCYs. The building
//! blocks here are pure types with no knowledge of a particular dictionary, so the linear wire
//! encoders ([`linear`]: SGH10, SGH50) and the rotary multiturn encoder (`rotary`: WV5800M)
//! share them:
//!
//! - [`SpeedEstimator`]: the difference of successive positions over an integration time;
//! - [`area_state`] and [`WorkAreas`]: the 6400h state bits from the 6401h/6402h limits (each
//!   encoder writes them at its resolved positions);
//! - [`alarms`] / [`warnings`]: the 6503h/6505h bits;
//! - [`operating_status`]: 6500h from 6000h;
//! - [`OperatingTime`]: the 6508h hour meter in tenths of an hour;
//! - [`EmcyConditions`]: edge detection of error conditions in front of [`emcy::set_error`].
//!
//! The decisions behind the semantics are in `docs/decisions.md`, "Encoder profile (CiA 406)".

pub mod linear;
pub mod rotary;

use crate::context::Context as Core;
use crate::device::{Device, Link};
use crate::emcy;
use crate::od::CoreHook;
use crate::od::{Entry, Od};
use crate::time::Instant;

/// Why the sensor gave no usable reading. Any fault makes the position value invalid:
/// 6503h bit 0 and the manufacturer EMCY "position value error" (FF05h) until a good
/// reading arrives.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SensorFault {
    /// The sensor's own diagnosis flagged the reading (magnet lost, signal amplitude out of
    /// range, internal checksum).
    Diagnosis,
    /// The sensor did not answer within its sample period.
    NoResponse,
    /// The reading lies outside the sensor's physical range.
    OutOfRange,
}

/// A CiA 406 encoder: a [`Device`] that also takes sensor samples.
pub trait Encoder: Device {
    /// One sensor reading at `now`: the device's raw count as its 600Ch defines it (the
    /// physical measuring steps before direction, scaling and calibration), or the fault that
    /// prevented it. Updates the position, speed, work-area, alarm and warning objects and the
    /// EMCYs. The shell calls it every [`Encoder::sample_period_us`].
    fn on_sample(&mut self, core: &mut Core, raw: Result<u32, SensorFault>, now: Instant);

    /// How often the shell samples the sensor, in microseconds.
    fn sample_period_us(&self) -> u32;
}

/// The encoders' cyclic timer 6200h and their TPDO1 event timer 1800h.05 are one value in two
/// objects: a write to either follows TPDO1's event-timer rules (the device's
/// [`Device::link`]) and sets both.
pub const CYCLE_TIMER_LINK: Link = Link { index: 0x1800, sub: 5, hook: CoreHook::PdoEventTimer };

/// Two entries that hold one value in two storage groups (an encoder's 6200h cyclic timer and
/// its TPDO1 event timer 1800h.05, or the WV58MR's 3000h.03), at `first` and `second`, made
/// equal after a reset: the one that differs from its default wins, `first` when both do.
pub fn merge_linked(od: &mut Od, first: usize, second: usize) {
    let (va, vb) = (od.get(first), od.get(second));
    let v = if va != od.entry(first).default_value(0) || vb == od.entry(second).default_value(0) { va } else { vb };
    od.set(first, v);
    od.set(second, v);
}

/// Programs the factory serial number (what the production line does once): 1018h.04, the
/// LSS address part, and 650Bh, the CiA 406 serial number, hold the same value. Both are
/// factory data: a user store or restore never changes them.
pub fn program_serial(od: &mut Od, serial: u32) {
    od.set_value(0x1018, 4, serial);
    od.set_value(0x650B, 0, serial);
}

/// The position of (index, sub) in `table`, found when the table is declared (a `const`): a
/// device resolves the entries its per-sample path reads and writes once, at compile time,
/// instead of looking each up at every sample. Fails the build if the entry is not declared.
pub const fn position(table: &[Entry], index: u16, sub: u8) -> u8 {
    let mut i = 0;
    while i < table.len() {
        if table[i].index == index && table[i].sub == sub {
            assert!(i < u8::MAX as usize, "a position fits a byte");
            return i as u8;
        }
        i += 1;
    }
    panic!("entry not declared")
}

/// The position of (index, sub) in `table` as [`position`] finds it, or [`ABSENT`] if the
/// table does not declare it.
pub const fn position_if(table: &[Entry], index: u16, sub: u8) -> u8 {
    let mut i = 0;
    while i < table.len() {
        if table[i].index == index && table[i].sub == sub {
            assert!(i < ABSENT as usize, "a position fits a byte");
            return i as u8;
        }
        i += 1;
    }
    ABSENT
}

/// [`position_if`] of an entry the table does not declare.
pub const ABSENT: u8 = u8::MAX;

/// A position difference over a measured time, as [`SpeedEstimator::push`] reports it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Window {
    /// Position change over the window, in the caller's counts (positive: increasing).
    pub delta: i64,
    /// Length of the window in microseconds (never 0).
    pub elapsed_us: u64,
}

impl Window {
    /// The rate `delta / elapsed` expressed in a unit of `num / den` counts per second,
    /// rounded to the nearest integer (halves away from zero).
    ///
    /// Example: counts of 0.1 mm and a result in mm/s is `rate(1, 10)`; raw increments and a
    /// result in increments per ms is `rate(1, 1000)`; a 6031h multiplier `m` and divisor `d`
    /// on top give `rate(m, 1000 * d)`.
    pub fn rate(&self, num: i64, den: i64) -> i64 {
        let n = self.delta as i128 * num as i128 * 1_000_000;
        let d = self.elapsed_us as i128 * den as i128;
        if d == 0 {
            return 0;
        }
        let (n, d) = if d < 0 { (-n, -d) } else { (n, d) };
        // |n| + d/2 over d, the sign put back: rounding halves away from zero, as the signed
        // division did, by the small unsigned long division (a speed is rare and needs no
        // speed; the library's 128-bit division is over 1 KiB of flash).
        let q = crate::arith::div_u128(n.unsigned_abs() + (d as u128) / 2, d as u128);
        let q = q.min(i64::MAX as u128 + 1) as i128;
        (if n < 0 { -q } else { q }).clamp(i64::MIN as i128, i64::MAX as i128) as i64
    }
}

impl Window {
    /// `delta × mul × scale / (elapsed_us × div)`, rounded to nearest (halves away from zero),
    /// in 64 bits: what [`Window::rate`] gives for `rate(mul × scale, 10^6 × div / ...)` once the
    /// common factors are cancelled (the same number, so the same rounding), without the
    /// 128-bit arithmetic. Exact while `|delta| × mul × scale` and `elapsed_us × div` stay
    /// below 2^64; beyond, they saturate. `div` 0 counts as 1.
    pub fn ratio(&self, mul: u32, scale: u32, div: u32) -> i64 {
        use crate::arith::{div_u64, mul_sat};
        let n = mul_sat(mul_sat(self.delta.unsigned_abs(), mul), scale);
        let d = mul_sat(self.elapsed_us, div.max(1));
        let q = div_u64(n.saturating_add(d / 2), d);
        if self.delta < 0 {
            (q.min(1 << 63) as i64).wrapping_neg()
        } else {
            q.min(i64::MAX as u64) as i64
        }
    }
}

/// Speed from successive positions: the difference between the first sample of a window and
/// the first sample at least one integration time later.
///
/// Feed it every sample with [`SpeedEstimator::push`]; each time a window closes it returns
/// the [`Window`] and starts the next one at that sample, so windows follow each other without
/// gaps and the speed is updated once per integration time. A fault interrupts the series:
/// call [`SpeedEstimator::reset`], and the next good sample opens a fresh window.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct SpeedEstimator {
    integration_us: u64,
    start: Option<(Instant, i64)>,
}

impl SpeedEstimator {
    /// An estimator over `integration_us` microseconds (at least 1).
    pub const fn new(integration_us: u64) -> SpeedEstimator {
        SpeedEstimator { integration_us: if integration_us == 0 { 1 } else { integration_us }, start: None }
    }

    /// The integration time in microseconds.
    pub const fn integration_us(&self) -> u64 {
        self.integration_us
    }

    /// Changes the integration time; the running window closes on the new length.
    pub fn set_integration_us(&mut self, integration_us: u64) {
        self.integration_us = integration_us.max(1);
    }

    /// Forgets the running window.
    pub fn reset(&mut self) {
        self.start = None;
    }

    /// Takes the position `value` (in continuous counts: the caller unwraps a wrapping sensor,
    /// see [`shortest_delta`]) sampled at `now`. Returns the window that closes at this
    /// sample, if the integration time has elapsed since the window opened.
    pub fn push(&mut self, now: Instant, value: i64) -> Option<Window> {
        match self.start {
            None => {
                self.start = Some((now, value));
                None
            }
            Some((t0, v0)) => {
                let elapsed_us = now.micros_since(t0);
                if elapsed_us >= self.integration_us && elapsed_us > 0 {
                    self.start = Some((now, value));
                    Some(Window { delta: value.wrapping_sub(v0), elapsed_us })
                } else {
                    None
                }
            }
        }
    }
}

/// The signed shortest difference `new - old` on a circle of `modulus` counts (a multiturn
/// counter that wraps): the result lies in `-modulus/2 ..= (modulus-1)/2`. A modulus of 0 means
/// no wrap (plain difference).
pub const fn shortest_delta(new: i64, old: i64, modulus: u32) -> i64 {
    let d = new.wrapping_sub(old);
    if modulus == 0 {
        return d;
    }
    let m = modulus as i64;
    let mut r = crate::arith::rem_euclid(d, modulus) as i64;
    if r > (m - 1) / 2 {
        r -= m;
    }
    r
}

/// 6400h bit 0: the position is outside the work area.
pub const AREA_OUTSIDE: u8 = 1 << 0;
/// 6400h bit 1: the position is above the high limit (6402h).
pub const AREA_ABOVE: u8 = 1 << 1;
/// 6400h bit 2: the position is below the low limit (6401h).
pub const AREA_BELOW: u8 = 1 << 2;

/// The 6400h state of one work area for `position` with limits `low` (6401h) and `high`
/// (6402h): inclusive limits, so a position equal to a limit is inside (CiA 406). With
/// `low > high` no position is inside; both "above" and "below" can then be set.
pub const fn area_state(position: i64, low: i64, high: i64) -> u8 {
    let mut s = 0;
    if position > high {
        s |= AREA_ABOVE;
    }
    if position < low {
        s |= AREA_BELOW;
    }
    if s != 0 {
        s |= AREA_OUTSIDE;
    }
    s
}

/// The two work areas of a CiA 406 encoder as the dictionary holds them: limits in
/// 6401h.01/.02 and 6402h.01/.02 (INTEGER32, or UNSIGNED32 on a rotary encoder), states in
/// 6400h.01/.02.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct WorkAreas {
    /// The last 6400h states, work area 1 and 2.
    pub state: [u8; 2],
}

impl WorkAreas {
    /// Is work area `k` (0 or 1) violated?
    pub const fn outside(&self, k: usize) -> bool {
        self.state[k] & AREA_OUTSIDE != 0
    }
}

/// 6503h bit 0: position value invalid (sensor fault).
pub const ALARM_POSITION: u16 = 1 << 0;
/// 6503h bit 12: work area 1 limit exceeded or undershot.
pub const ALARM_AREA_1: u16 = 1 << 12;
/// 6503h bit 13: work area 2 limit exceeded or undershot.
pub const ALARM_AREA_2: u16 = 1 << 13;
/// 6505h bit 0: speed outside its limits (maximum or 2003h/2004h limit speeds).
pub const WARNING_SPEED: u16 = 1 << 0;

/// The 6503h alarm word: position invalid, work areas violated; masked with the device's
/// supported alarms (6504h).
pub const fn alarms(position_invalid: bool, areas: &WorkAreas, supported: u16) -> u16 {
    let mut a = 0;
    if position_invalid {
        a |= ALARM_POSITION;
    }
    if areas.outside(0) {
        a |= ALARM_AREA_1;
    }
    if areas.outside(1) {
        a |= ALARM_AREA_2;
    }
    a & supported
}

/// The 6505h warning word: speed out of range; masked with the supported warnings (6506h).
pub const fn warnings(speed: bool, supported: u16) -> u16 {
    (if speed { WARNING_SPEED } else { 0 }) & supported
}

/// 6500h operating status: the 6000h operating parameters the device implements (`mask`:
/// counting direction and scaling bits), mirrored.
pub const fn operating_status(operating_parameters: u16, mask: u16) -> u16 {
    operating_parameters & mask
}

/// The 6508h operating hour meter: time powered, in tenths of an hour (CiA 406), counted from
/// the value stored at power-on.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct OperatingTime {
    base: u32,
    since: Instant,
}

/// Microseconds in a tenth of an hour.
const TENTH_HOUR_US: u64 = 360_000_000;

impl OperatingTime {
    /// A meter that held `stored` tenths of an hour at `now` (power-on).
    pub const fn new(stored: u32, now: Instant) -> OperatingTime {
        OperatingTime { base: stored, since: now }
    }

    /// The meter at `now`, saturating at FFFFFFFEh (FFFFFFFFh means "not supported").
    pub const fn at(&self, now: Instant) -> u32 {
        let tenths = now.micros_since(self.since) / TENTH_HOUR_US;
        let v = self.base as u64 + tenths;
        if v >= 0xFFFF_FFFE {
            0xFFFF_FFFE
        } else {
            v as u32
        }
    }
}

/// Most conditions one [`EmcyConditions`] tracks.
pub const MAX_CONDITIONS: usize = 16;

/// One EMCY-reported error condition of a device: its code and the 1001h bits it sets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Condition {
    /// EMCY error code (FF05h, FF15h, 8120h ...).
    pub code: u16,
    /// 1001h bits besides bit 0 (bit 4 communication, bit 7 manufacturer).
    pub register: u8,
}

/// Which of a device's conditions (numbered 0..[`MAX_CONDITIONS`]) are active: calls
/// [`emcy::set_error`] only on an edge, so a condition evaluated at every sample raises its
/// EMCY once and clears it once ("only once per error event").
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct EmcyConditions {
    active: u16,
}

impl EmcyConditions {
    /// No condition active.
    pub const fn new() -> EmcyConditions {
        EmcyConditions { active: 0 }
    }

    /// Sets condition number `n` (`cond`) to `active`; on a change reports it to the EMCY
    /// producer. Returns true on a change.
    pub fn update(&mut self, core: &mut Core, n: usize, cond: Condition, active: bool, now: Instant) -> bool {
        let bit = 1u16 << (n % MAX_CONDITIONS);
        if (self.active & bit != 0) == active {
            return false;
        }
        self.active ^= bit;
        emcy::set_error(core, cond.code, cond.register, active, now);
        true
    }

    /// Sets conditions `0 .. conds.len()` at once, condition `n` ([`Condition`] `conds[n]`)
    /// to bit `n` of `wanted`, and reports each that changed, in the order of `conds`: what
    /// [`EmcyConditions::update`] does for each in turn, in one loop over a table.
    pub fn update_all(&mut self, core: &mut Core, conds: &[Condition], wanted: u16, now: Instant) {
        for (n, cond) in conds.iter().enumerate() {
            let bit = 1u16 << (n % MAX_CONDITIONS);
            if (self.active ^ wanted) & bit != 0 {
                self.active ^= bit;
                emcy::set_error(core, cond.code, cond.register, wanted & bit != 0, now);
            }
        }
    }

    /// Is condition `n` active?
    pub const fn is_active(&self, n: usize) -> bool {
        self.active & (1 << (n % MAX_CONDITIONS)) != 0
    }

    /// Forgets every condition without reporting (the EMCY producer was reset with the node's
    /// communication; conditions still present are raised again by the next evaluation).
    pub fn forget(&mut self) {
        self.active = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rate as the signed 128-bit division gives it.
    fn rate_by_i128(w: &Window, num: i64, den: i64) -> i64 {
        let n = w.delta as i128 * num as i128 * 1_000_000;
        let d = w.elapsed_us as i128 * den as i128;
        if d == 0 {
            return 0;
        }
        let (n, d) = if d < 0 { (-n, -d) } else { (n, d) };
        let half = d / 2;
        let q = if n >= 0 { (n + half) / d } else { (n - half) / d };
        q.clamp(i64::MIN as i128, i64::MAX as i128) as i64
    }

    #[test]
    fn rate_rounds_as_the_signed_division() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..100_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let w = Window { delta: (x as i64) >> (x % 40), elapsed_us: (x >> 44) + 1 };
            for (num, den) in
                [(1, 10), (1, 1000), (3, 7000), (-5, 3), (1, -10), ((x >> 50) as i64, 1000 * ((x >> 54) as i64 + 1))]
            {
                assert_eq!(w.rate(num, den), rate_by_i128(&w, num, den), "{w:?} {num}/{den}");
            }
        }
    }

    #[test]
    fn rate_rounds_to_nearest_and_keeps_the_sign() {
        let w = Window { delta: 25, elapsed_us: 100_000 };
        // 25 × 0.1 mm in 100 ms = 25 mm/s.
        assert_eq!(w.rate(1, 10), 25);
        let w = Window { delta: -3, elapsed_us: 200_000 };
        // -0.3 mm in 0.2 s = -1.5 mm/s → -2 (half away from zero).
        assert_eq!(w.rate(1, 10), -2);
        // Raw increments per ms: 1000 increments in 100 ms = 10 Inc/ms.
        assert_eq!(Window { delta: 1000, elapsed_us: 100_000 }.rate(1, 1000), 10);
    }

    #[test]
    fn speed_windows_follow_each_other() {
        let mut s = SpeedEstimator::new(100_000);
        assert_eq!(s.push(Instant::from_millis(0), 0), None);
        assert_eq!(s.push(Instant::from_millis(50), 5), None);
        assert_eq!(s.push(Instant::from_millis(100), 10), Some(Window { delta: 10, elapsed_us: 100_000 }));
        assert_eq!(s.push(Instant::from_millis(150), 12), None);
        assert_eq!(s.push(Instant::from_millis(210), 4), Some(Window { delta: -6, elapsed_us: 110_000 }));
        s.reset();
        assert_eq!(s.push(Instant::from_millis(400), 100), None);
    }

    #[test]
    fn shortest_delta_unwraps_a_multiturn_counter() {
        assert_eq!(shortest_delta(2, 262_142, 262_144), 4);
        assert_eq!(shortest_delta(262_142, 2, 262_144), -4);
        assert_eq!(shortest_delta(7, 3, 0), 4);
        assert_eq!(shortest_delta(0, 8, 16), -8);
    }

    #[test]
    fn area_state_has_inclusive_limits() {
        assert_eq!(area_state(10, 10, 20), 0);
        assert_eq!(area_state(20, 10, 20), 0);
        assert_eq!(area_state(21, 10, 20), AREA_OUTSIDE | AREA_ABOVE);
        assert_eq!(area_state(9, 10, 20), AREA_OUTSIDE | AREA_BELOW);
        assert_eq!(area_state(15, 20, 10), AREA_OUTSIDE | AREA_ABOVE | AREA_BELOW);
    }

    #[test]
    fn alarm_and_warning_words() {
        let areas = WorkAreas { state: [AREA_OUTSIDE | AREA_ABOVE, 0] };
        assert_eq!(alarms(true, &areas, 0x3001), 0x1001);
        assert_eq!(alarms(false, &areas, 0x0001), 0);
        assert_eq!(warnings(true, 0x0001), 1);
        assert_eq!(warnings(true, 0), 0);
        assert_eq!(operating_status(0x000C, 0x000C), 0x000C);
    }

    #[test]
    fn operating_time_counts_tenths_of_an_hour() {
        let t = OperatingTime::new(5, Instant::from_millis(1000));
        assert_eq!(t.at(Instant::from_millis(1000)), 5);
        assert_eq!(t.at(Instant::from_millis(1000 + 359_999)), 5);
        assert_eq!(t.at(Instant::from_millis(1000 + 360_000)), 6);
        assert_eq!(
            OperatingTime::new(0xFFFF_FFF0, Instant::ZERO).at(Instant::from_millis(u32::MAX as u64 * 1000)),
            0xFFFF_FFFE
        );
    }
}
