//! The linear wire-actuated encoders (SGH10, SGH50): the position pipeline from the sensor's
//! wire extension to the position value, and the device behaviour both manuals share.
//!
//! # The position pipeline
//!
//! The sensor reports the pulled-out wire length in micrometres (the raw value; the SGH
//! manuals define no 600Ch). From it:
//!
//! 1. scaling (6005h.01, nm per step): `steps = raw_um * 1000 / resolution_nm`, truncated;
//!    a reading beyond the measuring range (`max_steps`) is invalid;
//! 2. counting direction (6000h bit 3): `measured = steps` (ascending, wire out = larger
//!    values) or `-steps` (descending);
//! 3. calibration (6010h.01): `position = measured - offset` where the offset (6509h and
//!    650Ch.01) is "the difference between the encoder value and the position value"; writing
//!    the calibration value `C` sets `offset = measured - C`, so the position becomes `C` at
//!    once ("position value = 0 + calibration value") and then moves with the wire
//!    ("position value = measured value + calibration value", measured from the calibration
//!    point).
//!
//! A change of the counting direction negates the offset, so the position value is mirrored
//! about zero (`p -> -p`) and keeps following the wire; the manuals ask for a new calibration
//! after it, and the mirrored value is what the device shows until then.
//!
//! The decisions are in `docs/decisions.md`, "Encoder profile (CiA 406)", "SGH10", "SGH50".

use crate::abort::Abort;
use crate::context::{BusEvent, CanError, Context as Core, ResetKind};
use crate::encoder::{
    alarms, area_state, operating_status, position as at, warnings, Condition, EmcyConditions, SensorFault,
    SpeedEstimator, WorkAreas,
};
use crate::od::{Entry, Od};
use crate::time::Instant;

/// Device-specific write hooks of the linear encoders (`Hook::Device(n)`).
pub mod hooks {
    /// 6000h operating parameters: counting direction.
    pub const OPERATING_PARAMETERS: u8 = 1;
    /// 6010h.01: calibrate to the written value.
    pub const CALIBRATE: u8 = 2;
    /// 6200h cycle timer and 1800h.05 event timer: one value in two objects.
    pub const CYCLE_TIMER: u8 = 3;
    /// 6401h/6402h work-area limits.
    pub const WORK_AREA: u8 = 4;
}

/// 6000h bit 3: descending position values when the wire is pulled out.
pub const DIRECTION_BIT: u16 = 1 << 3;
/// 6000h bit 2: scaling enabled (always set on the SGH encoders).
pub const SCALING_BIT: u16 = 1 << 2;

/// EMCY FF05h: position value error (sensor fault).
pub const EMCY_POSITION: Condition = Condition { code: 0xFF05, register: 0x80 };
/// EMCY FF12h: speed error (SGH10 only): the speed of the last window cannot be represented in
/// 6030h.01 at the step width 6005h.02 (it saturates). A sensor fault is FF05h alone (issue 13
/// point 11, D-SGH10-8).
pub const EMCY_SPEED: Condition = Condition { code: 0xFF12, register: 0x80 };
/// EMCY FF15h: position error work area 1.
pub const EMCY_AREA_1: Condition = Condition { code: 0xFF15, register: 0x80 };
/// EMCY FF16h: position error work area 2.
pub const EMCY_AREA_2: Condition = Condition { code: 0xFF16, register: 0x80 };
/// EMCY 8120h: CAN controller error passive.
pub const EMCY_PASSIVE: Condition = Condition { code: 0x8120, register: 0x10 };
/// EMCY 8140h: recovered from bus-off.
pub const EMCY_BUS_OFF: Condition = Condition { code: 0x8140, register: 0x10 };

// Condition numbers in `EmcyConditions`.
const C_POSITION: usize = 0;
const C_AREA_1: usize = 1;
const C_AREA_2: usize = 2;
const C_SPEED: usize = 3;
const C_PASSIVE: usize = 4;
const C_BUS_OFF: usize = 5;
/// The conditions [`Linear`] sets from its state at every evaluation, in condition-number
/// order (the bus-off recovery, an event, is reported on its own).
const CONDITIONS: [Condition; 5] = [EMCY_POSITION, EMCY_AREA_1, EMCY_AREA_2, EMCY_SPEED, EMCY_PASSIVE];

/// Measuring steps of a raw wire extension `raw_um` (µm) at `resolution_nm` nm per step,
/// truncated towards zero. A resolution of 0 (never accepted by 6005h) gives 0.
///
/// `raw_um * 1000 / resolution_nm` without a 64-bit division (a library routine of about 1 KiB
/// on the Cortex-M3, and slow, on the per-sample path): the whole steps by one 32-bit division,
/// then the three decimal digits of the remainder's fraction by subtraction.
pub const fn steps(raw_um: u32, resolution_nm: u32) -> i64 {
    if resolution_nm == 0 {
        return 0;
    }
    let whole = (raw_um / resolution_nm) as i64 * 1000;
    let mut rest = (raw_um % resolution_nm) as u64;
    let d = resolution_nm as u64;
    let mut fraction = 0i64;
    let mut digit = 0;
    while digit < 3 {
        // rest < d: rest * 10 < 10 d, so the digit is below 10.
        rest *= 10;
        let mut n = 0;
        while rest >= d {
            rest -= d;
            n += 1;
        }
        fraction = fraction * 10 + n;
        digit += 1;
    }
    whole + fraction
}

/// The measured value: `steps` in the counting direction.
pub const fn measured(steps: i64, descending: bool) -> i64 {
    if descending {
        -steps
    } else {
        steps
    }
}

/// The position value of `measured` with `offset` (6509h).
pub const fn position(measured: i64, offset: i64) -> i64 {
    measured - offset
}

/// The offset (6509h) that makes the position equal `calibration_value` at `measured`.
pub const fn calibration_offset(measured: i64, calibration_value: i64) -> i64 {
    measured - calibration_value
}

/// The speed value (6030h.01 units, 6005h.02 × 0.01 mm/s) of a window of `delta` steps of
/// `resolution_nm` over `elapsed_us`, rounded to nearest (halves away from zero). Not
/// saturated.
///
/// [`crate::encoder::Window::rate`]`(resolution_nm, speed_step × 10000)` in 64 bits: `delta ×
/// res × 10^6 / (elapsed × step × 10^4)` is `delta × res × 100 / (elapsed × step)`, the same
/// number, so the same rounding. Exact while `|delta| × resolution_nm` stays below 2^56,
/// which a linear encoder's window always does (its steps times the resolution are at most
/// 1000 times a 32-bit reading in µm, below 2^42); larger products saturate.
pub fn speed_value(window: crate::encoder::Window, resolution_nm: u32, speed_step: u32) -> i64 {
    window.ratio(resolution_nm, 100, speed_step)
}

/// Where the linear encoder's objects sit in its device's table ([`Entries::of`], resolved
/// when the table is declared), so the per-sample path reads and writes them without a lookup.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Entries {
    /// 6000h operating parameters.
    pub operating: u8,
    /// 6005h.01 position step setting (nm).
    pub resolution: u8,
    /// 6005h.02 speed step setting.
    pub speed_step: u8,
    /// 6010h.01 calibration value.
    pub calibration: u8,
    /// 6020h.01 position value.
    pub position: u8,
    /// 6030h.01 speed value.
    pub speed: u8,
    /// 6200h cyclic timer.
    pub cycle_timer: u8,
    /// 1800h.05 TPDO1 event timer.
    pub event_timer: u8,
    /// 6400h.01/.02 work-area states.
    pub area_state: [u8; 2],
    /// 6401h.01/.02 work-area low limits.
    pub area_low: [u8; 2],
    /// 6402h.01/.02 work-area high limits.
    pub area_high: [u8; 2],
    /// 6500h operating status.
    pub status: u8,
    /// 6503h alarms.
    pub alarms: u8,
    /// 6504h supported alarms.
    pub supported_alarms: u8,
    /// 6505h warnings.
    pub warnings: u8,
    /// 6506h supported warnings.
    pub supported_warnings: u8,
    /// 6509h offset value.
    pub offset: u8,
    /// 650Ch.01 offset value channel 1.
    pub offset_1: u8,
    /// 5000h CAN diagnosis.
    pub diagnosis: u8,
    /// 1002h manufacturer status register (the error counters).
    pub counters: u8,
}

impl Entries {
    /// The positions in `table`, which must declare every object of a linear encoder (a
    /// `const`: the build fails otherwise).
    pub const fn of(table: &[Entry]) -> Entries {
        Entries {
            operating: at(table, 0x6000, 0),
            resolution: at(table, 0x6005, 1),
            speed_step: at(table, 0x6005, 2),
            calibration: at(table, 0x6010, 1),
            position: at(table, 0x6020, 1),
            speed: at(table, 0x6030, 1),
            cycle_timer: at(table, 0x6200, 0),
            event_timer: at(table, 0x1800, 5),
            area_state: [at(table, 0x6400, 1), at(table, 0x6400, 2)],
            area_low: [at(table, 0x6401, 1), at(table, 0x6401, 2)],
            area_high: [at(table, 0x6402, 1), at(table, 0x6402, 2)],
            status: at(table, 0x6500, 0),
            alarms: at(table, 0x6503, 0),
            supported_alarms: at(table, 0x6504, 0),
            warnings: at(table, 0x6505, 0),
            supported_warnings: at(table, 0x6506, 0),
            offset: at(table, 0x6509, 0),
            offset_1: at(table, 0x650C, 1),
            diagnosis: at(table, 0x5000, 0),
            counters: at(table, 0x1002, 0),
        }
    }
}

/// What distinguishes one linear encoder from another.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LinearSpec {
    /// Largest valid reading in measuring steps (the wire fully out); readings beyond are a
    /// sensor fault.
    pub max_steps: i64,
    /// Does the manual list EMCY FF12h "speed error"?
    pub speed_error: bool,
    /// Speed integration time in microseconds.
    pub integration_us: u32,
    /// Sensor sample period in microseconds.
    pub sample_period_us: u32,
    /// Where the objects sit in the device's table.
    pub entries: &'static Entries,
}

/// The CAN error ranking of 5000h: how often each kind occurred (acknowledge, form, CRC,
/// stuff) and the resulting ranks.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct CanDiagnosis {
    counts: [u32; 4],
}

impl CanDiagnosis {
    /// Counts one protocol error. Bit errors have no 5000h byte and are not counted.
    pub fn count(&mut self, e: CanError) {
        let k = match e {
            CanError::Acknowledge => 0,
            CanError::Form => 1,
            CanError::Crc => 2,
            CanError::Stuff => 3,
            CanError::Bit => return,
        };
        self.counts[k] = self.counts[k].saturating_add(1);
    }

    /// The 5000h value: byte 0 acknowledge, 1 form, 2 CRC, 3 stuff; each 0 when the kind never
    /// occurred, else 4 minus the number of kinds that occurred more often (4 = most
    /// frequent; equal counts share a rank).
    pub fn ranking(&self) -> u32 {
        let mut v = 0u32;
        for (k, &c) in self.counts.iter().enumerate() {
            if c == 0 {
                continue;
            }
            let more = self.counts.iter().filter(|&&o| o > c).count() as u32;
            v |= (4 - more) << (8 * k);
        }
        v
    }
}

/// The behaviour both linear encoders share; the devices (`devices::sgh10`,
/// `devices::sgh50`) delegate to it.
#[derive(Clone, Debug)]
pub struct Linear {
    spec: LinearSpec,
    speed: SpeedEstimator,
    areas: WorkAreas,
    conditions: EmcyConditions,
    /// Last valid reading in measuring steps, `None` before the first sample and while the
    /// sensor fails.
    steps: Option<i64>,
    /// The sensor's last reading was a fault.
    fault: bool,
    /// The last window's speed does not fit 6030h.01 (saturated).
    speed_fault: bool,
    /// The controller is error passive.
    passive: bool,
    /// A bus-off recovery waits to be reported.
    recovered: bool,
    can: CanDiagnosis,
    started: bool,
}

impl Linear {
    /// The shared behaviour for an encoder described by `spec`.
    pub const fn new(spec: LinearSpec) -> Linear {
        Linear {
            spec,
            speed: SpeedEstimator::new(spec.integration_us as u64),
            areas: WorkAreas { state: [0; 2] },
            conditions: EmcyConditions::new(),
            steps: None,
            fault: false,
            speed_fault: false,
            passive: false,
            recovered: false,
            can: CanDiagnosis { counts: [0; 4] },
            started: false,
        }
    }

    /// The device description.
    pub const fn spec(&self) -> &LinearSpec {
        &self.spec
    }

    /// The last valid reading in measuring steps, if any.
    pub const fn steps(&self) -> Option<i64> {
        self.steps
    }

    /// The last valid measured value (steps in the counting direction of `od`), if any.
    fn measured(&self, od: &Od) -> Option<i64> {
        self.steps.map(|s| measured(s, self.descending(od)))
    }

    /// Is the position value invalid (sensor fault)?
    pub const fn fault(&self) -> bool {
        self.fault
    }

    fn get(&self, od: &Od, pos: u8) -> u32 {
        od.get(pos as usize)
    }

    fn set(&self, od: &mut Od, pos: u8, value: u32) {
        od.set(pos as usize, value);
    }

    fn descending(&self, od: &Od) -> bool {
        self.get(od, self.spec.entries.operating) as u16 & DIRECTION_BIT != 0
    }

    fn offset(&self, od: &Od) -> i64 {
        self.get(od, self.spec.entries.offset) as i32 as i64
    }

    fn set_offset(&self, od: &mut Od, offset: i64) {
        let v = offset.clamp(i32::MIN as i64, i32::MAX as i64) as i32 as u32;
        self.set(od, self.spec.entries.offset, v);
        self.set(od, self.spec.entries.offset_1, v);
    }

    fn set_position(&self, od: &mut Od, p: i64) {
        self.set(od, self.spec.entries.position, p.clamp(i32::MIN as i64, i32::MAX as i64) as i32 as u32);
    }

    /// The position value of the last valid reading, its offset and direction from `od`.
    fn update_position(&self, od: &mut Od) {
        if let Some(m) = self.measured(od) {
            self.set_position(od, position(m, self.offset(od)));
        }
    }

    fn set_status(&self, od: &mut Od, operating: u16) {
        self.set(od, self.spec.entries.status, operating_status(operating, DIRECTION_BIT | SCALING_BIT) as u32);
    }

    /// Brings the derived objects in line with the dictionary after power-on or a reset.
    fn start(&mut self, core: &mut Core, kind: ResetKind) {
        let at = self.spec.entries;
        let od = &mut core.od;
        self.set_status(od, self.get(od, at.operating) as u16);
        // 6200h and 1800h.05 are one value in two objects of two storage groups: after a
        // reset, the one that differs from its default wins, 1800h.05 when both do.
        crate::encoder::merge_linked(od, at.event_timer as usize, at.cycle_timer as usize);
        if kind == ResetKind::Node {
            // 6010h.01 is not stored: the application starts with its default.
            let p = at.calibration as usize;
            od.set(p, od.entry(p).default_value(0));
            self.speed.reset();
        }
        // The CAN diagnosis belongs to the communication, which both resets re-initialise.
        self.can = CanDiagnosis::default();
        self.set(od, at.diagnosis, 0);
        // The EMCY producer keeps the active conditions over a reset (and announces them
        // again after the boot-up), so the edge tracker keeps them too.
        self.started = true;
    }

    fn ensure_started(&mut self, core: &mut Core) {
        if !self.started {
            self.start(core, ResetKind::Node);
        }
    }

    /// Takes a sensor sample (see [`crate::encoder::Encoder::on_sample`]).
    pub fn on_sample(&mut self, core: &mut Core, raw: Result<u32, SensorFault>, now: Instant) {
        self.ensure_started(core);
        let at = self.spec.entries;
        let od = &mut core.od;
        let resolution = self.get(od, at.resolution);
        let reading = raw.and_then(|um| {
            let s = steps(um, resolution);
            if s > self.spec.max_steps {
                Err(SensorFault::OutOfRange)
            } else {
                Ok(s)
            }
        });
        match reading {
            Ok(s) => {
                let m = measured(s, self.descending(od));
                self.fault = false;
                self.steps = Some(s);
                self.set_position(od, position(m, self.offset(od)));
                if let Some(w) = self.speed.push(now, m) {
                    let v = speed_value(w, resolution, self.get(od, at.speed_step));
                    self.speed_fault = v > i16::MAX as i64 || v < i16::MIN as i64;
                    let v = v.clamp(i16::MIN as i64, i16::MAX as i64) as i16;
                    self.set(od, at.speed, v as u16 as u32);
                }
            }
            Err(_) => {
                self.fault = true;
                self.steps = None;
                // No speed either, until a whole integration time of good readings. 6030h.01
                // reads 0, which it can represent: no speed error (FF05h reports the fault).
                self.speed.reset();
                self.speed_fault = false;
                self.set(od, at.speed, 0);
            }
        }
        self.evaluate(core, now);
    }

    /// Recomputes the work areas, alarms and warnings from the current position and reports
    /// every condition that changed.
    fn evaluate(&mut self, core: &mut Core, now: Instant) {
        let at = self.spec.entries;
        let od = &mut core.od;
        if self.steps.is_some() {
            let p = self.get(od, at.position) as i32 as i64;
            for k in 0..2 {
                let low = self.get(od, at.area_low[k]) as i32 as i64;
                let high = self.get(od, at.area_high[k]) as i32 as i64;
                let s = area_state(p, low, high);
                self.areas.state[k] = s;
                self.set(od, at.area_state[k], s as u32);
            }
        }
        let supported = self.get(od, at.supported_alarms) as u16;
        self.set(od, at.alarms, alarms(self.fault, &self.areas, supported) as u32);
        let supported = self.get(od, at.supported_warnings) as u16;
        self.set(od, at.warnings, warnings(self.speed_fault, supported) as u32);
        self.report(core, now);
    }

    /// Reports the EMCY conditions that changed (the producer holds back what falls due
    /// before the boot-up).
    fn report(&mut self, core: &mut Core, now: Instant) {
        let wanted = (self.fault as u16) << C_POSITION
            | (self.areas.outside(0) as u16) << C_AREA_1
            | (self.areas.outside(1) as u16) << C_AREA_2
            | ((self.spec.speed_error && self.speed_fault) as u16) << C_SPEED
            | (self.passive as u16) << C_PASSIVE;
        let c = &mut self.conditions;
        c.update_all(core, &CONDITIONS, wanted, now);
        if self.recovered {
            // The recovery is an event: reported once the bus works again, and cleared at
            // once, since its cause (the bus-off) is gone.
            self.recovered = false;
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, true, now);
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, false, now);
        }
    }

    /// Checks and applies a write to an entry with a linear-encoder hook.
    pub fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        self.ensure_started(core);
        let e = core.od.entry(pos);
        let hook = match e.hook {
            crate::od::Hook::Device(h) => h,
            _ => return Ok(()),
        };
        match hook {
            hooks::OPERATING_PARAMETERS => {
                let v = value as u16;
                // Scaling cannot be switched off; bits other than 2 and 3 are unused.
                if v & !(DIRECTION_BIT | SCALING_BIT) != 0 || v & SCALING_BIT == 0 {
                    return Err(Abort::INVALID_VALUE);
                }
                let od = &mut core.od;
                let old = od.get(pos) as u16;
                od.set(pos, v as u32);
                if (old ^ v) & DIRECTION_BIT != 0 {
                    // Mirror the position about zero: the measured value changes sign, and
                    // so does the offset.
                    self.set_offset(od, -self.offset(od));
                    self.update_position(od);
                    let at = self.spec.entries.speed;
                    let speed = self.get(od, at) as u16 as i16;
                    self.set(od, at, speed.saturating_neg() as u16 as u32);
                    self.speed.reset();
                }
                self.set_status(od, v);
            }
            hooks::CALIBRATE => {
                let m = self.measured(&core.od).ok_or(Abort::NO_DATA)?;
                let c = value as i32 as i64;
                let od = &mut core.od;
                self.set_offset(od, calibration_offset(m, c));
                self.set_position(od, position(m, self.offset(od)));
            }
            // The access path has applied the TPDO1 event-timer rule ([`Linear::link`]); the
            // two entries hold one value.
            hooks::CYCLE_TIMER => {
                self.set(&mut core.od, self.spec.entries.event_timer, value);
                self.set(&mut core.od, self.spec.entries.cycle_timer, value);
            }
            hooks::WORK_AREA => core.od.set(pos, value),
            _ => return Ok(()),
        }
        self.evaluate(core, now);
        Ok(())
    }

    /// After a reset (the dictionary already reloaded).
    pub fn on_reset(&mut self, core: &mut Core, kind: ResetKind, now: Instant) {
        self.start(core, kind);
        // The offset and the direction may have been reloaded.
        self.update_position(&mut core.od);
        self.speed.reset();
        self.evaluate(core, now);
    }

    /// Device timers: EMCY conditions held back until the boot-up.
    pub fn poll(&mut self, core: &mut Core, now: Instant) {
        self.ensure_started(core);
        self.report(core, now);
    }

    /// The CAN controller reported `event`.
    pub fn on_bus_event(&mut self, core: &mut Core, event: BusEvent, now: Instant) {
        self.ensure_started(core);
        match event {
            BusEvent::ErrorPassive => self.passive = true,
            BusEvent::ErrorActive => self.passive = false,
            BusEvent::BusOff => {}
            BusEvent::BusOffRecovered => {
                self.passive = false;
                self.recovered = true;
            }
            BusEvent::RxOverrun => {}
            BusEvent::ProtocolError(e) => {
                self.can.count(e);
                self.set(&mut core.od, self.spec.entries.diagnosis, self.can.ranking());
            }
            BusEvent::ErrorCounters { rx, tx } => {
                self.set(&mut core.od, self.spec.entries.counters, rx as u32 | (tx as u32) << 8);
            }
        }
        self.report(core, now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encoder::Window;

    #[test]
    fn steps_equal_the_64_bit_quotient() {
        let mut x = 1u32;
        for _ in 0..20_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let raw = x.rotate_left(7);
            for res in [1, 7, 999, 1000, 1001, 100_000, 123_457, x >> 3 | 1, u32::MAX] {
                assert_eq!(steps(raw, res), raw as i64 * 1000 / res as i64, "{raw} / {res}");
            }
        }
        assert_eq!(steps(u32::MAX, 1), u32::MAX as i64 * 1000);
    }

    #[test]
    fn scaling_truncates_to_tenths_of_a_millimetre() {
        assert_eq!(steps(0, 100_000), 0);
        assert_eq!(steps(99, 100_000), 0);
        assert_eq!(steps(100, 100_000), 1);
        assert_eq!(steps(1_023_900, 100_000), 10239);
        assert_eq!(steps(u32::MAX, 100_000), 42_949_672);
    }

    #[test]
    fn calibration_sets_the_position_and_follows_the_wire() {
        let m = measured(1234, false);
        let o = calibration_offset(m, 510);
        assert_eq!(position(m, o), 510);
        assert_eq!(position(measured(1244, false), o), 520);
        // Descending: pulling the wire out lowers the value.
        let m = measured(1234, true);
        let o = calibration_offset(m, 510);
        assert_eq!(position(measured(1244, true), o), 500);
    }

    #[test]
    fn speed_in_millimetres_per_second() {
        // 25 steps of 0.1 mm in 100 ms = 25 mm/s at 6005h.02 = 100 (1 mm/s per digit).
        let w = Window { delta: 25, elapsed_us: 100_000 };
        assert_eq!(speed_value(w, 100_000, 100), 25);
        let w = Window { delta: -50, elapsed_us: 100_000 };
        assert_eq!(speed_value(w, 100_000, 100), -50);
    }

    #[test]
    fn speed_equals_the_128_bit_rate() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..100_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            // A window's steps times the resolution stay below 1000 × 2^32: the
            // steps are at most 1000 × µm / resolution.
            let res = [100_000, 1, 7, 999, (x >> 40) as u32 | 1, u32::MAX][(x % 6) as usize];
            let limit = (1000u64 << 32) / res as u64;
            let delta = ((x >> 7) % (2 * limit + 1)) as i64 - limit as i64;
            let elapsed_us = [100_000, 101_000, 1, (x >> 24) + 1, u64::MAX][((x >> 3) % 5) as usize];
            let step = [100, 1, 0, 3, (x >> 33) as u32, u32::MAX][((x >> 5) % 6) as usize];
            let w = Window { delta, elapsed_us };
            assert_eq!(
                speed_value(w, res, step),
                w.rate(res as i64, step.max(1) as i64 * 10_000),
                "{w:?} {res} {step}"
            );
        }
    }

    #[test]
    fn can_error_ranking() {
        let mut d = CanDiagnosis::default();
        assert_eq!(d.ranking(), 0);
        for _ in 0..3 {
            d.count(CanError::Acknowledge);
        }
        d.count(CanError::Crc);
        d.count(CanError::Stuff);
        d.count(CanError::Bit);
        // ack most frequent (4), CRC and stuff share the next rank (3), form never (0).
        assert_eq!(d.ranking(), 0x0303_0004);
        for _ in 0..5 {
            d.count(CanError::Form);
        }
        assert_eq!(d.ranking(), 0x0202_0403);
    }
}
