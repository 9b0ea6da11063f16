//! WV5800M / WH5800M absolute rotary encoder, singleturn or 4/8/12-bit multiturn: the object
//! dictionary of its manual (SIKO art. no. 90107, mod. status 170/20), every row, with the
//! manual's types, access rights, defaults and limits, and the device behaviour.
//!
//! The manual covers two mechanical versions (WV, WH: 1008h) and four measuring ranges
//! (1000h, 6002h, 6502h, the 2001h/6003h/6401h/6402h ranges and 650Ah.03). Each of the eight
//! combinations has its own `static` table, built by one `const fn` so the rows are written
//! once. Only [`Wv5800m::new`] (inlined) names them and the device keeps the chosen one, so a
//! firmware that builds one constant variant lets the linker drop the other seven.
//!
//! The position pipeline is [`crate::encoder::rotary`]; the CiA 406 blocks (speed windows, EMCY
//! edges, alarm words, CAN diagnosis) are shared with the linear encoders. The decisions are in
//! `docs/decisions.md`, "WV5800M".

use crate::abort::Abort;
use crate::context::{BusEvent, Context as Core, ResetKind};
use crate::device::{CanopenDevice, CanopenStatus, Device, Link};
use crate::devices::comm::{self, CanOpen, Identity, NodeIdAndBitrate, Pdo, Profile, Serial};
use crate::encoder::linear::{CanDiagnosis, EMCY_AREA_1, EMCY_AREA_2, EMCY_BUS_OFF, EMCY_PASSIVE, EMCY_POSITION};
use crate::encoder::rotary::{
    self, limit_speed, over_speed, raw_delta, speed_value, work_area_state, Scaling, DIRECTION_BIT, MAX_APU,
    PHYSICAL_STEPS, SCALING_BIT,
};
use crate::encoder::{
    alarms, operating_status, position as at, position_if, warnings, Condition, EmcyConditions, Encoder, SensorFault,
    SpeedEstimator, WorkAreas, ABSENT, CYCLE_TIMER_LINK,
};
use crate::led::{LedInputs, Leds, WARNING_LIMIT};
use crate::od::{Access::*, DataType::*, Entry, Group, Hook, Od};
use crate::time::Instant;

/// Device-specific write hooks of the WV5800M (`Hook::Device(n)`).
pub mod hooks {
    /// 6000h operating parameters: counting direction.
    pub const OPERATING_PARAMETERS: u8 = 1;
    /// 6001h measuring steps per revolution: rescales, sets 6002h and 650Ah.03.
    pub const APU: u8 = 2;
    /// 6002h total measuring range: only APU × revolutions.
    pub const TOTAL_RANGE: u8 = 3;
    /// 6003h calibration value, 6401h/6402h work-area limits: `0 ..= 6002h − 1`.
    pub const IN_RANGE: u8 = 4;
    /// 2001h application offset: moves the position, mirrored in 650Ah.01.
    pub const OFFSET: u8 = 5;
    /// 2002h: calibrate ("zero" the measured value).
    pub const CALIBRATE: u8 = 6;
    /// 2003h/2004h limit speeds.
    pub const LIMIT_SPEED: u8 = 7;
    /// 6200h cycle timer and 1800h.05 event timer: one value in two objects.
    pub const CYCLE_TIMER: u8 = 8;
}

const APP: Group = Group::App;
const MANUF: Group = Group::Manuf;
const fn dev(h: u8) -> Hook {
    Hook::Device(h)
}

/// Default node-ID ex works.
pub const DEFAULT_NODE_ID: u8 = 1;
/// Default 5F0Ah.02 bit-rate code (5 = 500 kbit/s).
pub const DEFAULT_BITRATE_CODE: u8 = 5;
/// Entries in each WV5800M dictionary.
pub const ENTRIES: usize = 102;
/// Sensor sample period (the manual names none).
pub const SAMPLE_PERIOD_US: u32 = 1_000;

/// The mechanical version: the manual describes no difference but the name in 1008h.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Model {
    /// WV5800M.
    Wv,
    /// WH5800M.
    Wh,
}

impl Model {
    /// The manufacturer device name (1008h).
    pub const fn name(self) -> &'static str {
        match self {
            Model::Wv => "WV5800M",
            Model::Wh => "WH5800M",
        }
    }
}

/// The measuring range: singleturn or 4, 8, 12-bit multiturn.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Turns {
    /// Singleturn (1 revolution).
    Single,
    /// 4-bit multiturn (16 revolutions).
    Multi4,
    /// 8-bit multiturn (256 revolutions).
    Multi8,
    /// 12-bit multiturn (4096 revolutions).
    Multi12,
}

impl Turns {
    /// Distinguishable revolutions (6502h).
    pub const fn revolutions(self) -> u32 {
        match self {
            Turns::Single => 1,
            Turns::Multi4 => 16,
            Turns::Multi8 => 256,
            Turns::Multi12 => 4096,
        }
    }

    /// Device type (1000h): 0x00010196 singleturn, 0x00020196 multiturn.
    pub const fn device_type(self) -> u32 {
        match self {
            Turns::Single => 0x0001_0196,
            _ => 0x0002_0196,
        }
    }
}

/// A product variant: version and measuring range.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Variant {
    /// WV or WH.
    pub model: Model,
    /// Measuring range.
    pub turns: Turns,
}

/// The TPDOs: TPDO1 (asynchronous, its event timer the 6200h cycle timer) and TPDO2
/// (synchronous), both mapping the position (6004h) and the speed (6030h.01).
const TPDOS: [Pdo; 2] =
    [Pdo::new(0xFE, &TPDO_MAPPING).event_timer(dev(hooks::CYCLE_TIMER)), Pdo::new(0x01, &TPDO_MAPPING)];
const TPDO_MAPPING: [u32; 2] = [0x6004_0020, 0x6030_0110];

/// What the communication profile (1000h-1FFFh) of a `model` with `turns` declares; [`comm`]
/// writes the rows.
const fn profile(model: Model, turns: Turns) -> Profile {
    Profile {
        device_type: turns.device_type(),
        status_register: true,
        device_name: Some(model.name()),
        hardware_version: Some("V001"),
        software_version: "V001",
        identity: Identity::siko(Serial::Factory(1)),
        heads: Const,
        canopen: Some(CanOpen { rpdos: &[], tpdos: &TPDOS }),
    }
}

/// 5F0Ah.
const NODE: NodeIdAndBitrate = NodeIdAndBitrate::new(DEFAULT_NODE_ID, (1, 127), DEFAULT_BITRATE_CODE, (1, 7));

/// The dictionary of a `model` with `turns`.
const fn table(model: Model, turns: Turns) -> [Entry; ENTRIES] {
    let n = turns.revolutions() as i64;
    // Raw range = default total range (APU 16384); the largest total range (APU 65535).
    let r = PHYSICAL_STEPS as i64 * n;
    let max_pos = MAX_APU as i64 * n - 1;
    comm::join(&[
        comm::rows(&profile(model, turns)).as_slice(),
        &[
            Entry::var(0x2001, "Application offset", Integer32, Rw, 0)
                .range(-r, r - 1)
                .group(MANUF)
                .hook(dev(hooks::OFFSET)),
            Entry::var(0x2002, "Calibrate encoder value", Unsigned8, Wo, 0).range(0, 1).hook(dev(hooks::CALIBRATE)),
            Entry::var(0x2003, "Limit speed low", Integer16, Rw, 0).group(MANUF).hook(dev(hooks::LIMIT_SPEED)),
            Entry::var(0x2004, "Limit speed high", Integer16, Rw, 0).group(MANUF).hook(dev(hooks::LIMIT_SPEED)),
            Entry::var(0x5000, "Diagnosis CAN bus error", Unsigned32, Ro, 0),
        ],
        comm::node_id_and_bitrate(&NODE).as_slice(),
        &[
            Entry::var(0x6000, "Operating parameters", Unsigned16, Rw, SCALING_BIT as u32)
                .range(SCALING_BIT as i64, (SCALING_BIT | DIRECTION_BIT) as i64)
                .group(APP)
                .hook(dev(hooks::OPERATING_PARAMETERS)),
            Entry::var(0x6001, "Measuring steps per revolution", Unsigned32, Rw, PHYSICAL_STEPS)
                .range(1, MAX_APU as i64)
                .group(APP)
                .hook(dev(hooks::APU)),
            Entry::var(0x6002, "Total measuring range in measuring steps", Unsigned32, Rw, r as u32)
                .range(n, max_pos + 1)
                .group(APP)
                .hook(dev(hooks::TOTAL_RANGE)),
            Entry::var(0x6003, "Preset value", Integer32, Rw, 0)
                .range(0, max_pos)
                .group(APP)
                .hook(dev(hooks::IN_RANGE)),
            Entry::var(0x6004, "Position value", Unsigned32, Ro, 0).pdo(),
            Entry::var(0x600C, "Position raw value", Unsigned32, Ro, 0).pdo(),
            Entry::array(0x6030, "Speed value", 1, Ro),
            Entry::member(0x6030, 1, "Speed value channel 1", Integer16, Ro, 0).pdo(),
            Entry::record(0x6031, "Speed parameters", 4, Ro),
            Entry::member(0x6031, 1, "Speed source selector", Unsigned8, Rw, 2).range(2, 2).group(APP),
            Entry::member(0x6031, 2, "Speed integration time", Unsigned16, Ro, 100).group(APP),
            Entry::member(0x6031, 3, "Speed multiplier", Unsigned16, Rw, 1).range(1, 1).group(APP),
            Entry::member(0x6031, 4, "Speed divisor", Unsigned16, Rw, 1).range(1, 1).group(APP),
            Entry::var(0x6200, "Cyclic timer", Unsigned16, Rw, 0).group(APP).hook(dev(hooks::CYCLE_TIMER)),
        ],
        &rotary::status_rows(turns.revolutions(), dev(hooks::IN_RANGE)),
    ])
}

static WV_1: [Entry; ENTRIES] = table(Model::Wv, Turns::Single);
static WV_16: [Entry; ENTRIES] = table(Model::Wv, Turns::Multi4);
static WV_256: [Entry; ENTRIES] = table(Model::Wv, Turns::Multi8);
static WV_4096: [Entry; ENTRIES] = table(Model::Wv, Turns::Multi12);
static WH_1: [Entry; ENTRIES] = table(Model::Wh, Turns::Single);
static WH_16: [Entry; ENTRIES] = table(Model::Wh, Turns::Multi4);
static WH_256: [Entry; ENTRIES] = table(Model::Wh, Turns::Multi8);
static WH_4096: [Entry; ENTRIES] = table(Model::Wh, Turns::Multi12);

/// The dictionary of `variant`, sorted by (index, sub).
#[inline]
pub const fn table_of(variant: Variant) -> &'static [Entry] {
    match (variant.model, variant.turns) {
        (Model::Wv, Turns::Single) => &WV_1,
        (Model::Wv, Turns::Multi4) => &WV_16,
        (Model::Wv, Turns::Multi8) => &WV_256,
        (Model::Wv, Turns::Multi12) => &WV_4096,
        (Model::Wh, Turns::Single) => &WH_1,
        (Model::Wh, Turns::Multi4) => &WH_16,
        (Model::Wh, Turns::Multi8) => &WH_256,
        (Model::Wh, Turns::Multi12) => &WH_4096,
    }
}

/// Where the encoder's objects sit in a rotary encoder's table ([`Entries::of`], resolved when
/// the table is declared), so the per-sample path reads and writes them without a lookup. The
/// eight WV5800M tables share one layout ([`WV5800M_ENTRIES`]); the WV58MR's have their own.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Entries {
    /// 2001h application offset.
    pub offset: u8,
    /// 2003h limit speed low.
    pub limit_low: u8,
    /// 2004h limit speed high.
    pub limit_high: u8,
    /// 5000h CAN diagnosis.
    pub diagnosis: u8,
    /// 6000h operating parameters.
    pub operating: u8,
    /// 6001h measuring steps per revolution.
    pub apu: u8,
    /// 6002h total measuring range.
    pub total: u8,
    /// 6003h preset value.
    pub preset: u8,
    /// 6004h position value.
    pub position: u8,
    /// 600Ch position raw value.
    pub raw: u8,
    /// 6030h.01 speed value.
    pub speed: u8,
    /// 6031h.03 speed multiplier.
    pub multiplier: u8,
    /// 6031h.04 speed divisor.
    pub divisor: u8,
    /// 6200h cyclic timer.
    pub cycle_timer: u8,
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
    /// 6509h calibration (offset value).
    pub calibration: u8,
    /// 650Ah.01 manufacturer offset value.
    pub module_offset: u8,
    /// 650Ah.03 manufacturer maximum position value.
    pub largest: u8,
    /// 1800h.05 TPDO1 event timer ([`ABSENT`] without CANopen).
    pub event_timer: u8,
    /// 1002h manufacturer status register ([`ABSENT`] if not declared).
    pub counters: u8,
}

impl Entries {
    /// The positions in `table`, which must declare every CiA 406 object of the rotary encoder
    /// (a `const`: the build fails otherwise); 1800h.05 and 1002h may be absent.
    pub const fn of(table: &[Entry]) -> Entries {
        Entries {
            offset: at(table, 0x2001, 0),
            limit_low: at(table, 0x2003, 0),
            limit_high: at(table, 0x2004, 0),
            diagnosis: at(table, 0x5000, 0),
            operating: at(table, 0x6000, 0),
            apu: at(table, 0x6001, 0),
            total: at(table, 0x6002, 0),
            preset: at(table, 0x6003, 0),
            position: at(table, 0x6004, 0),
            raw: at(table, 0x600C, 0),
            speed: at(table, 0x6030, 1),
            multiplier: at(table, 0x6031, 3),
            divisor: at(table, 0x6031, 4),
            cycle_timer: at(table, 0x6200, 0),
            area_state: [at(table, 0x6400, 1), at(table, 0x6400, 2)],
            area_low: [at(table, 0x6401, 1), at(table, 0x6401, 2)],
            area_high: [at(table, 0x6402, 1), at(table, 0x6402, 2)],
            status: at(table, 0x6500, 0),
            alarms: at(table, 0x6503, 0),
            supported_alarms: at(table, 0x6504, 0),
            warnings: at(table, 0x6505, 0),
            supported_warnings: at(table, 0x6506, 0),
            calibration: at(table, 0x6509, 0),
            module_offset: at(table, 0x650A, 1),
            largest: at(table, 0x650A, 3),
            event_timer: position_if(table, 0x1800, 5),
            counters: position_if(table, 0x1002, 0),
        }
    }
}

/// The positions in every WV5800M table (they share one layout; a test checks all eight).
pub static WV5800M_ENTRIES: Entries = Entries::of(&WV_4096);

/// EMCY FF12h: velocity error, the maximum speed (6000 rpm) exceeded.
pub const EMCY_VELOCITY: Condition = Condition { code: 0xFF12, register: 0x80 };
/// EMCY FF13h: error limit speed low (below 2003h).
pub const EMCY_LIMIT_LOW: Condition = Condition { code: 0xFF13, register: 0x80 };
/// EMCY FF14h: error limit speed high (above 2004h).
pub const EMCY_LIMIT_HIGH: Condition = Condition { code: 0xFF14, register: 0x80 };

// Condition numbers in `EmcyConditions`.
const C_POSITION: usize = 0;
const C_AREA_1: usize = 1;
const C_AREA_2: usize = 2;
const C_VELOCITY: usize = 3;
const C_LIMIT_LOW: usize = 4;
const C_LIMIT_HIGH: usize = 5;
const C_PASSIVE: usize = 6;
const C_BUS_OFF: usize = 7;
/// The conditions set from the encoder's state at every evaluation, in condition-number order
/// (the bus-off recovery, an event, is reported on its own).
const CONDITIONS: [Condition; 7] =
    [EMCY_POSITION, EMCY_AREA_1, EMCY_AREA_2, EMCY_VELOCITY, EMCY_LIMIT_LOW, EMCY_LIMIT_HIGH, EMCY_PASSIVE];

/// A WV5800M / WH5800M.
#[derive(Clone, Debug)]
pub struct Wv5800m {
    variant: Variant,
    /// The variant's dictionary, chosen once in [`Wv5800m::new`] so that only `new` names the
    /// eight tables: a firmware that builds one variant links one table.
    table: &'static [Entry],
    /// Where the objects sit in `table`.
    at: &'static Entries,
    speed: SpeedEstimator,
    /// Last valid raw count (600Ch), `None` before the first sample and while the sensor fails.
    raw: Option<u32>,
    /// Directed raw counts summed over every sample since the speed series began (unwrapped).
    travel: i64,
    fault: bool,
    over_speed: bool,
    limit_low: bool,
    limit_high: bool,
    areas: WorkAreas,
    conditions: EmcyConditions,
    passive: bool,
    recovered: bool,
    bus_off: bool,
    warning: bool,
    can: CanDiagnosis,
    started: bool,
    /// The node's status, for the LEDs.
    status: CanopenStatus,
}

impl Wv5800m {
    /// An encoder of `variant`, before its first sensor sample.
    #[inline]
    pub fn new(variant: Variant) -> Wv5800m {
        Wv5800m {
            variant,
            table: table_of(variant),
            at: &WV5800M_ENTRIES,
            speed: SpeedEstimator::new(100_000),
            raw: None,
            travel: 0,
            fault: false,
            over_speed: false,
            limit_low: false,
            limit_high: false,
            areas: WorkAreas { state: [0; 2] },
            conditions: EmcyConditions::new(),
            passive: false,
            recovered: false,
            bus_off: false,
            warning: false,
            can: CanDiagnosis::default(),
            started: false,
            status: CanopenStatus::default(),
        }
    }

    /// The variant.
    pub const fn variant(&self) -> Variant {
        self.variant
    }

    /// Is the position value invalid (sensor fault)?
    pub const fn fault(&self) -> bool {
        self.fault
    }

    /// Is the maximum speed exceeded (yellow LED, 6505h bit 0, FF12h)?
    pub const fn over_speed(&self) -> bool {
        self.over_speed
    }

    /// The same encoder behaviour over another dictionary with this variant's rows (the
    /// J1939 WV58MR's: same CiA 406 objects, same hooks 1..=5 and 7), its objects at `at`.
    pub(crate) fn with_table(variant: Variant, table: &'static [Entry], at: &'static Entries) -> Wv5800m {
        Wv5800m { table, at, ..Wv5800m::new(variant) }
    }

    fn get(&self, od: &Od, pos: u8) -> u32 {
        od.get(pos as usize)
    }

    fn set(&self, od: &mut Od, pos: u8, value: u32) {
        od.set(pos as usize, value);
    }

    /// The last valid raw count (600Ch), `None` before the first sample and while the sensor
    /// fails.
    pub const fn raw(&self) -> Option<u32> {
        self.raw
    }

    /// The CAN controller's state as the device last heard it: (bus-off, an error counter at
    /// the warning limit or error passive).
    pub const fn can_state(&self) -> (bool, bool) {
        (self.bus_off, self.warning || self.passive)
    }

    /// Recomputes the derived objects (6002h, 650Ah, 6500h, 6004h), the work areas, alarms,
    /// warnings and error conditions after the dictionary changed outside [`Device::on_write`].
    pub(crate) fn refresh(&mut self, core: &mut Core, now: Instant) {
        self.ensure_started(core);
        self.derive(&mut core.od);
        self.evaluate(core, now);
    }

    /// What the three LEDs show now ([`Leds::lit`] gives the blink phase at an instant): the
    /// node's status as it last told the device ([`CanopenDevice::on_status`]) and the
    /// device's own conditions.
    pub fn leds(&self) -> Leds {
        Leds::from_inputs(&LedInputs {
            nmt: self.status.nmt,
            lss_configuration: self.status.lss_configuration,
            bus_off: self.bus_off,
            warning_limit: self.warning || self.passive,
            guard_event: self.status.life_guard_event,
            over_speed: self.over_speed,
        })
    }

    /// The scaling the dictionary holds now.
    pub fn scaling(&self, od: &Od) -> Scaling {
        let at = self.at;
        let n = self.variant.turns.revolutions();
        let r = rotary::raw_range(n);
        Scaling {
            revolutions: n,
            apu: self.get(od, at.apu).clamp(1, MAX_APU),
            ccw: self.get(od, at.operating) as u16 & DIRECTION_BIT != 0,
            calibration: rotary::wrap(self.get(od, at.calibration) as i32, r),
            preset: self.get(od, at.preset) as i32,
            offset: self.get(od, at.offset) as i32,
        }
    }

    /// Sets the objects derived from the scaling: 6002h, 650Ah.01/.03, 6500h, and 6004h from
    /// the last valid reading.
    fn derive(&self, od: &mut Od) {
        let at = self.at;
        let s = self.scaling(od);
        self.set(od, at.total, s.total());
        self.set(od, at.module_offset, s.offset as u32);
        self.set(od, at.largest, s.largest());
        let op = self.get(od, at.operating) as u16;
        self.set(od, at.status, operating_status(op, DIRECTION_BIT | SCALING_BIT) as u32);
        if let Some(raw) = self.raw {
            self.set(od, at.position, s.position(raw));
        }
    }

    /// Brings the derived objects in line with the dictionary after power-on or a reset.
    fn start(&mut self, core: &mut Core) {
        let od = &mut core.od;
        // 6200h and 1800h.05 are one value in two objects of two storage groups: after a
        // reset, the one that differs from its default wins, 1800h.05 when both do.
        let at = self.at;
        if at.event_timer != ABSENT {
            crate::encoder::merge_linked(od, at.event_timer as usize, at.cycle_timer as usize);
        }
        self.derive(od);
        self.speed.reset();
        self.can = CanDiagnosis::default();
        self.set(od, at.diagnosis, 0);
        self.started = true;
    }

    fn ensure_started(&mut self, core: &mut Core) {
        if !self.started {
            self.start(core);
        }
    }

    /// Recomputes work areas, alarms and warnings and reports the EMCY conditions.
    fn evaluate(&mut self, core: &mut Core, now: Instant) {
        let at = self.at;
        let od = &mut core.od;
        if self.raw.is_some() {
            let p = self.get(od, at.position);
            for k in 0..2 {
                let low = self.get(od, at.area_low[k]) as i32;
                let high = self.get(od, at.area_high[k]) as i32;
                let s = work_area_state(p, low, high);
                self.areas.state[k] = s;
                self.set(od, at.area_state[k], s as u32);
            }
        }
        let speed = self.get(od, at.speed) as u16 as i16 as i64;
        let low = self.get(od, at.limit_low) as u16 as i16;
        let high = self.get(od, at.limit_high) as u16 as i16;
        (self.limit_low, self.limit_high) = if self.fault { (false, false) } else { limit_speed(speed, low, high) };
        let supported = self.get(od, at.supported_alarms) as u16;
        self.set(od, at.alarms, alarms(self.fault, &self.areas, supported) as u32);
        let supported = self.get(od, at.supported_warnings) as u16;
        let warn = self.over_speed || self.limit_low || self.limit_high;
        self.set(od, at.warnings, warnings(warn, supported) as u32);
        self.report(core, now);
    }

    fn report(&mut self, core: &mut Core, now: Instant) {
        let wanted = (self.fault as u16) << C_POSITION
            | (self.areas.outside(0) as u16) << C_AREA_1
            | (self.areas.outside(1) as u16) << C_AREA_2
            | (self.over_speed as u16) << C_VELOCITY
            | (self.limit_low as u16) << C_LIMIT_LOW
            | (self.limit_high as u16) << C_LIMIT_HIGH
            | (self.passive as u16) << C_PASSIVE;
        let c = &mut self.conditions;
        c.update_all(core, &CONDITIONS, wanted, now);
        if self.recovered {
            // An event: reported once the bus works again and cleared at once (D-ENC-5).
            self.recovered = false;
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, true, now);
            c.update(core, C_BUS_OFF, EMCY_BUS_OFF, false, now);
        }
    }
}

impl Device for Wv5800m {
    fn table(&self) -> &'static [Entry] {
        self.table
    }

    fn link(&self, e: &Entry) -> Option<Link> {
        (e.hook == Hook::Device(hooks::CYCLE_TIMER)).then_some(CYCLE_TIMER_LINK)
    }

    fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        self.ensure_started(core);
        let hook = match core.od.entry(pos).hook {
            Hook::Device(h) => h,
            _ => return Ok(()),
        };
        let before = self.scaling(&core.od);
        match hook {
            hooks::OPERATING_PARAMETERS => {
                let v = value as u16;
                // Scaling cannot be switched off; bits other than 0 and 2 are unused.
                if v & !(DIRECTION_BIT | SCALING_BIT) != 0 || v & SCALING_BIT == 0 {
                    return Err(Abort::INVALID_VALUE);
                }
                let ccw = v & DIRECTION_BIT != 0;
                if ccw != before.ccw {
                    let after = before.with_direction(ccw);
                    self.set(&mut core.od, self.at.calibration, after.calibration);
                    let speed = self.get(&core.od, self.at.speed) as u16 as i16;
                    self.set(&mut core.od, self.at.speed, speed.saturating_neg() as u16 as u32);
                    self.travel = -self.travel;
                    self.speed.reset();
                }
            }
            hooks::APU => {}
            hooks::TOTAL_RANGE => {
                // 6002h follows 6001h (APU × revolutions); no other total is possible.
                if value != before.apu * before.revolutions {
                    return Err(Abort::INVALID_VALUE);
                }
            }
            hooks::IN_RANGE => {
                if value as i32 as i64 > before.largest() as i64 {
                    return Err(Abort::INVALID_VALUE);
                }
            }
            hooks::OFFSET | hooks::LIMIT_SPEED => {}
            // 1 calibrates; 0, the printed default, does nothing (D-WV-4).
            hooks::CALIBRATE if value == 1 => {
                let raw = self.raw.ok_or(Abort::NO_DATA)?;
                self.set(&mut core.od, self.at.calibration, before.calibrated_at(raw));
            }
            hooks::CALIBRATE => {}
            // The access path has applied the TPDO1 event-timer rule (`link`); the two entries
            // hold one value.
            hooks::CYCLE_TIMER => {
                if self.at.event_timer != ABSENT {
                    self.set(&mut core.od, self.at.event_timer, value);
                }
                self.set(&mut core.od, self.at.cycle_timer, value);
            }
            _ => return Ok(()),
        }
        core.od.set(pos, value);
        self.derive(&mut core.od);
        self.evaluate(core, now);
        Ok(())
    }

    fn on_reset(&mut self, core: &mut Core, kind: ResetKind, now: Instant) {
        let _ = kind;
        self.start(core);
        self.evaluate(core, now);
    }

    fn poll(&mut self, core: &mut Core, now: Instant) {
        self.ensure_started(core);
        self.report(core, now);
    }

    fn on_bus_event(&mut self, core: &mut Core, event: BusEvent, now: Instant) {
        self.ensure_started(core);
        match event {
            BusEvent::ErrorPassive => self.passive = true,
            BusEvent::ErrorActive => self.passive = false,
            BusEvent::BusOff => self.bus_off = true,
            BusEvent::BusOffRecovered => {
                self.bus_off = false;
                self.passive = false;
                self.warning = false;
                self.recovered = true;
            }
            BusEvent::RxOverrun => {}
            BusEvent::ProtocolError(e) => {
                self.can.count(e);
                self.set(&mut core.od, self.at.diagnosis, self.can.ranking());
            }
            BusEvent::ErrorCounters { rx, tx } => {
                self.warning = rx >= WARNING_LIMIT || tx >= WARNING_LIMIT;
                if self.at.counters != ABSENT {
                    self.set(&mut core.od, self.at.counters, rx as u32 | (tx as u32) << 8);
                }
            }
        }
        self.report(core, now);
    }
}

impl CanopenDevice for Wv5800m {
    fn on_status(&mut self, status: CanopenStatus) {
        self.status = status;
    }
}

impl Encoder for Wv5800m {
    fn on_sample(&mut self, core: &mut Core, raw: Result<u32, SensorFault>, now: Instant) {
        self.ensure_started(core);
        let s = self.scaling(&core.od);
        let reading = raw.and_then(|r| if s.valid(r) { Ok(r) } else { Err(SensorFault::OutOfRange) });
        let at = self.at;
        let od = &mut core.od;
        match reading {
            Ok(r) => {
                if let Some(old) = self.raw {
                    self.travel += raw_delta(r, old, s.raw_range(), s.ccw);
                }
                self.fault = false;
                self.raw = Some(r);
                self.set(od, at.raw, r);
                self.set(od, at.position, s.position(r));
                if let Some(w) = self.speed.push(now, self.travel) {
                    let (mul, div) = (self.get(od, at.multiplier), self.get(od, at.divisor));
                    let v = speed_value(w, mul, div).clamp(i16::MIN as i64, i16::MAX as i64) as i16;
                    self.set(od, at.speed, v as u16 as u32);
                    self.over_speed = over_speed(w);
                }
            }
            Err(_) => {
                self.fault = true;
                self.raw = None;
                self.speed.reset();
                self.over_speed = false;
                self.set(od, at.speed, 0);
            }
        }
        self.evaluate(core, now);
    }

    fn sample_period_us(&self) -> u32 {
        SAMPLE_PERIOD_US
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [Variant; 8] = [
        Variant { model: Model::Wv, turns: Turns::Single },
        Variant { model: Model::Wv, turns: Turns::Multi4 },
        Variant { model: Model::Wv, turns: Turns::Multi8 },
        Variant { model: Model::Wv, turns: Turns::Multi12 },
        Variant { model: Model::Wh, turns: Turns::Single },
        Variant { model: Model::Wh, turns: Turns::Multi4 },
        Variant { model: Model::Wh, turns: Turns::Multi8 },
        Variant { model: Model::Wh, turns: Turns::Multi12 },
    ];

    #[test]
    fn every_table_has_the_objects_where_the_encoder_looks() {
        for model in [Model::Wv, Model::Wh] {
            for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
                assert_eq!(Entries::of(table_of(Variant { model, turns })), WV5800M_ENTRIES, "{model:?} {turns:?}");
            }
        }
        let od = Od::new(table_of(Variant { model: Model::Wv, turns: Turns::Multi4 }), 1);
        let at = WV5800M_ENTRIES;
        assert_eq!(od.pos(0x6031, 4), Some(at.divisor as usize));
        assert_eq!(od.pos(0x1800, 5), Some(at.event_timer as usize));
        assert_eq!(od.pos(0x1002, 0), Some(at.counters as usize));
        assert_eq!(od.pos(0x6402, 2), Some(at.area_high[1] as usize));
    }

    #[test]
    fn every_manual_row_is_declared() {
        for v in ALL {
            let t = table_of(v);
            // 102 rows in the digest's object table.
            assert_eq!(t.len(), ENTRIES);
            let od = Od::new(t, DEFAULT_NODE_ID);
            let n = v.turns.revolutions();
            assert_eq!(od.value(0x1000, 0), Some(v.turns.device_type()));
            assert_eq!(od.value(0x6002, 0), Some(16384 * n));
            assert_eq!(od.value(0x6502, 0), Some(n));
            assert_eq!(od.value(0x650A, 3), Some(16384 * n - 1));
            assert_eq!(od.value(0x1014, 0), Some(0x81));
            assert_eq!(od.value(0x1800, 1), Some(0x181));
            assert_eq!(od.value(0x1801, 1), Some(0x281));
            assert_eq!(od.value(0x6000, 0), Some(4));
            assert!(od.pos(0x1800, 4).is_none() && od.pos(0x1801, 6).is_none());
            let e = od.entry(od.pos(0x1008, 0).unwrap());
            assert_eq!(e.default(), crate::od::Default::Str(v.model.name()));
            let e = od.entry(od.pos(0x2001, 0).unwrap());
            assert_eq!(e.limits(), Some((-(16384 * n as i64), 16384 * n as i64 - 1)));
            let e = od.entry(od.pos(0x6003, 0).unwrap());
            assert_eq!(e.limits(), Some((0, 65535 * n as i64 - 1)));
        }
        // The WV and WH tables differ only in the name.
        for (a, b) in WV_4096.iter().zip(WH_4096.iter()) {
            if a.index != 0x1008 {
                assert_eq!(a, b);
            }
        }
    }
}
