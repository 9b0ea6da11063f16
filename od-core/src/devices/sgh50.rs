//! SGH50 absolute wire-actuated encoder, single or redundant: the object dictionary of its
//! manual (SIKO art. no. 89927, change version 020/22), every row, with the manual's types,
//! access rights, defaults and limits. 6003h and 6004h are "not used" and absent (06020000h);
//! 1800h/1801h sub 4 and 6 are "not used" and absent (06090011h).
//!
//! The redundant version is two encoders in one housing, each a complete node of this
//! firmware: factory node-IDs 1 and 2 and their own serial numbers, which is what LSS tells
//! them apart by (vendor, product code and revision are equal). Each encoder's factory default
//! of 5F0Ah.01 is its shipping node-ID, so a 1011h restore never puts both on node 1: both
//! share one table whose 5F0Ah.01 is marked [`Entry::factory_node_id`], the second encoder's
//! dictionary taking 2 for it ([`Device::factory_node_id`]).
//!
//! The behaviour is the linear CiA 406 encoder of [`crate::encoder::linear`] with the SGH50's
//! measuring range; the SGH50 manual lists no speed EMCY.

use crate::abort::Abort;
use crate::context::{BusEvent, Context as Core, ResetKind};
use crate::device::{CanopenDevice, Device, Link};
use crate::devices::comm::{self, CanOpen, Identity, NodeIdAndBitrate, Pdo, Profile, Serial};
use crate::encoder::linear::{Entries, Linear, LinearSpec};
use crate::encoder::{Encoder, SensorFault, CYCLE_TIMER_LINK};
use crate::od::{Access::*, DataType::*, Entry, Group, Hook};
use crate::time::Instant;

/// Device-specific write hooks of the SGH50 (`Hook::Device(n)`): the linear encoders' ones.
pub use crate::encoder::linear::hooks;

const APP: Group = Group::App;
const MANUF: Group = Group::Manuf;
const fn dev(h: u8) -> Hook {
    Hook::Device(h)
}

/// Default node-ID ex works of the single version and of the redundant version's first
/// encoder.
pub const DEFAULT_NODE_ID: u8 = 1;
/// Default node-ID ex works of the redundant version's second encoder.
pub const SECOND_NODE_ID: u8 = 2;
/// Default 5F0Ah.02 bit-rate code (5 = 500 kbit/s).
pub const DEFAULT_BITRATE_CODE: u8 = 5;
/// Entries in the SGH50 dictionary.
pub const ENTRIES: usize = 97;

/// What the SGH50's communication profile (1000h-1FFFh) declares; [`comm`] writes the rows.
const PROFILE: Profile = Profile {
    device_type: 0x000A_0196,
    status_register: true,
    device_name: Some("SGH50"),
    hardware_version: Some("V100"),
    software_version: "V100",
    identity: Identity::siko(Serial::Factory(1)),
    heads: Const,
    canopen: Some(CanOpen {
        rpdos: &[],
        tpdos: &[
            Pdo::new(0xFE, &TPDO_MAPPING).transmission_limits(0xFD, 0xFF).event_timer(dev(hooks::CYCLE_TIMER)),
            Pdo::new(0x01, &TPDO_MAPPING),
        ],
    }),
};
/// TPDO1 and TPDO2 both map the position (6020h.01) and the speed (6030h.01).
const TPDO_MAPPING: [u32; 2] = [0x6020_0120, 0x6030_0110];

/// The SGH50 dictionary with `node_id` as the declared default of 5F0Ah.01.
const fn table(node_id: u8) -> [Entry; ENTRIES] {
    comm::join(&[
        comm::rows(&PROFILE).as_slice(),
        &[
            Entry::var(0x5000, "Diagnose CAN bus error", Unsigned32, Ro, 0),
            Entry::var(0x5F09, "Bus terminal", Unsigned8, Rw, 0).range(0, 1).group(MANUF),
        ],
        comm::node_id_and_bitrate(&NodeIdAndBitrate::new(node_id, (1, 127), DEFAULT_BITRATE_CODE, (1, 7))).as_slice(),
        &[
            Entry::var(0x6000, "Operating parameters", Unsigned16, Rw, 0x0004)
                .range(0x0004, 0x000C)
                .group(APP)
                .hook(dev(hooks::OPERATING_PARAMETERS)),
            Entry::var(0x6002, "Total number of measuring steps", Unsigned32, Rw, 73840).group(APP),
            Entry::record(0x6005, "Linear encoder measuring step settings", 2, Ro),
            Entry::member(0x6005, 1, "Position step setting", Unsigned32, Rw, 100_000)
                .range(100_000, 100_000)
                .group(APP),
            Entry::member(0x6005, 2, "Speed step setting", Unsigned32, Rw, 100).range(100, 100).group(APP),
            Entry::array(0x6010, "Preset value for multi-sensor devices", 1, Ro),
            Entry::member(0x6010, 1, "Calibration value", Integer32, Rw, 0)
                .range(-73839, 73839)
                .pdo()
                .hook(dev(hooks::CALIBRATE)),
            Entry::array(0x6020, "Position value for multi-sensor devices", 1, Ro),
            Entry::member(0x6020, 1, "Position value", Integer32, Ro, 0).pdo(),
            Entry::array(0x6030, "Speed value", 1, Ro),
            Entry::member(0x6030, 1, "Speed value", Integer16, Ro, 0).pdo(),
            Entry::var(0x6200, "Cyclic timer", Unsigned16, Rw, 0).group(APP).hook(dev(hooks::CYCLE_TIMER)),
            Entry::array(0x6400, "Area state register", 2, Ro),
            Entry::member(0x6400, 1, "Work area state channel 1", Unsigned8, Ro, 0),
            Entry::member(0x6400, 2, "Work area state channel 2", Unsigned8, Ro, 0),
            Entry::array(0x6401, "Work area low limit", 2, Ro),
            Entry::member(0x6401, 1, "Work area low limit channel 1", Integer32, Rw, -147678i32 as u32)
                .range(-147678, 221517)
                .group(APP)
                .hook(dev(hooks::WORK_AREA)),
            Entry::member(0x6401, 2, "Work area low limit channel 2", Integer32, Rw, -147678i32 as u32)
                .range(-147678, 221517)
                .group(APP)
                .hook(dev(hooks::WORK_AREA)),
            Entry::array(0x6402, "Work area high limit", 2, Ro),
            Entry::member(0x6402, 1, "Work area high limit channel 1", Integer32, Rw, 221517)
                .range(-147678, 221517)
                .group(APP)
                .hook(dev(hooks::WORK_AREA)),
            Entry::member(0x6402, 2, "Work area high limit channel 2", Integer32, Rw, 221517)
                .range(-147678, 221517)
                .group(APP)
                .hook(dev(hooks::WORK_AREA)),
            Entry::var(0x6500, "Operating status", Unsigned16, Ro, 0x0004),
            Entry::var(0x6501, "Single-turn resolution", Unsigned32, Ro, 100_000),
            Entry::var(0x6502, "Number of distinguishable revolutions", Unsigned16, Ro, 1),
            Entry::var(0x6503, "Alarms", Unsigned16, Ro, 0),
            Entry::var(0x6504, "Supported alarms", Unsigned16, Ro, 0x3001),
            Entry::var(0x6505, "Warnings", Unsigned16, Ro, 0),
            Entry::var(0x6506, "Supported warnings", Unsigned16, Ro, 0),
            Entry::var(0x6507, "Profile and software version", Unsigned32, Ro, 0x0100_0302),
            Entry::var(0x6508, "Operating time", Unsigned32, Ro, 0xFFFF_FFFF),
            Entry::var(0x6509, "Offset value", Integer32, Ro, 0).group(APP),
            Entry::array(0x650A, "Module identification", 3, Ro),
            Entry::member(0x650A, 1, "Manufacturer offset value", Integer32, Ro, 0),
            Entry::member(0x650A, 2, "Manufacturer minimum position value", Integer32, Ro, -147678i32 as u32),
            Entry::member(0x650A, 3, "Manufacturer maximum position value", Integer32, Ro, 221517),
            Entry::var(0x650B, "Serial number", Unsigned32, Ro, 0).group(Group::Factory),
            Entry::array(0x650C, "Offset values for multi-sensor devices", 1, Ro),
            Entry::member(0x650C, 1, "Offset value channel 1", Integer32, Ro, 0).group(APP),
        ],
    ])
}

static TABLE_1: [Entry; ENTRIES] = table(DEFAULT_NODE_ID);

/// The SGH50 dictionary, sorted by (index, sub): both versions and both encoders of the
/// redundant one. 5F0Ah.01 is declared with default 1; the second encoder's dictionary has 2
/// as its factory node-ID ([`Variant::default_node_id`], [`Device::factory_node_id`]).
pub static TABLE: &[Entry] = &TABLE_1;

/// Is the internal CAN bus termination switched on (D-SGH50-5)? 5F09h = 1 switches it on, 0
/// off, at once (the SDO write is the switch), and the value the node powers on or resets with
/// (stored, or the default 0) is what the board applies from then on. The board drives its
/// termination switch from this at every turn of its loop.
pub fn bus_termination(core: &Core) -> bool {
    core.od.value(0x5F09, 0) == Some(1)
}

/// The SGH50's measuring range and timing.
pub const SPEC: LinearSpec = LinearSpec {
    // 6002h: 73840 steps of 0.1 mm; the calibration range is ±73839.
    max_steps: 73839,
    speed_error: false,
    integration_us: 100_000,
    sample_period_us: 1_000,
    entries: &ENTRIES_AT,
};

/// Where the linear encoder's objects sit in the table.
static ENTRIES_AT: Entries = Entries::of(&TABLE_1);

/// Which of the redundant version's two encoders.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Channel {
    /// The first encoder (node-ID 1 ex works).
    First,
    /// The second encoder (node-ID 2 ex works).
    Second,
}

/// The product variants of the manual.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Variant {
    /// The non-redundant version: one encoder.
    Single,
    /// One of the redundant version's two encoders (each is a node of its own).
    Redundant(Channel),
}

impl Variant {
    /// The node-ID the variant ships with.
    pub const fn default_node_id(self) -> u8 {
        match self {
            Variant::Redundant(Channel::Second) => SECOND_NODE_ID,
            _ => DEFAULT_NODE_ID,
        }
    }
}

/// An SGH50 encoder (one node).
#[derive(Clone, Debug)]
pub struct Sgh50 {
    variant: Variant,
    linear: Linear,
}

impl Sgh50 {
    /// An encoder of `variant`, before its first sensor sample.
    pub const fn new(variant: Variant) -> Sgh50 {
        Sgh50 { variant, linear: Linear::new(SPEC) }
    }

    /// The variant.
    pub const fn variant(&self) -> Variant {
        self.variant
    }

    /// The shared linear-encoder state.
    pub const fn linear(&self) -> &Linear {
        &self.linear
    }
}

impl Device for Sgh50 {
    fn table(&self) -> &'static [Entry] {
        TABLE
    }

    fn factory_node_id(&self) -> Option<u8> {
        match self.variant {
            Variant::Redundant(Channel::Second) => Some(SECOND_NODE_ID),
            _ => None,
        }
    }

    fn link(&self, e: &Entry) -> Option<Link> {
        (e.hook == Hook::Device(hooks::CYCLE_TIMER)).then_some(CYCLE_TIMER_LINK)
    }

    fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        self.linear.on_write(core, pos, value, now)
    }

    fn on_reset(&mut self, core: &mut Core, kind: ResetKind, now: Instant) {
        self.linear.on_reset(core, kind, now);
    }

    fn poll(&mut self, core: &mut Core, now: Instant) {
        self.linear.poll(core, now);
    }

    fn on_bus_event(&mut self, core: &mut Core, event: BusEvent, now: Instant) {
        self.linear.on_bus_event(core, event, now);
    }
}

impl CanopenDevice for Sgh50 {}

impl Encoder for Sgh50 {
    fn on_sample(&mut self, core: &mut Core, raw: Result<u32, SensorFault>, now: Instant) {
        self.linear.on_sample(core, raw, now);
    }

    fn sample_period_us(&self) -> u32 {
        SPEC.sample_period_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::Od;

    #[test]
    fn every_manual_row_is_declared() {
        // 103 rows in the digest's table; 6003h, 6004h and 1800h/1801h sub 4 and 6 are "not used".
        assert_eq!(TABLE.len(), 97);
        let od = Od::new(TABLE, DEFAULT_NODE_ID);
        assert_eq!(od.value(0x1000, 0), Some(0x000A_0196));
        assert_eq!(od.value(0x6002, 0), Some(73840));
        assert_eq!(od.value(0x6401, 2), Some(-147678i32 as u32));
        assert_eq!(od.value(0x6402, 1), Some(221517));
        assert_eq!(od.value(0x650A, 2), Some(0xFFFD_BF22));
        assert_eq!(od.value(0x650A, 3), Some(0x0003_614D));
        assert_eq!(od.value(0x5F09, 0), Some(0));
        assert_eq!(od.value(0x5F0A, 1), Some(1));
        assert!(od.pos(0x6003, 0).is_none() && od.pos(0x6004, 0).is_none());
        assert!(od.pos(0x1800, 4).is_none() && od.pos(0x1801, 6).is_none());
        let e = od.entry(od.pos(0x6010, 1).unwrap());
        assert_eq!(e.limits(), Some((-73839, 73839)));
    }

    #[test]
    fn the_second_encoder_differs_only_in_its_node_id_default() {
        let (first, second) =
            (Sgh50::new(Variant::Redundant(Channel::First)), Sgh50::new(Variant::Redundant(Channel::Second)));
        assert_eq!(first.table().as_ptr(), second.table().as_ptr(), "one table");
        let a = Od::with_factory_node_id(TABLE, DEFAULT_NODE_ID, first.factory_node_id());
        let b = Od::with_factory_node_id(TABLE, SECOND_NODE_ID, second.factory_node_id());
        for e in TABLE {
            if (e.index, e.sub) == (0x5F0A, 1) {
                assert_eq!((a.default_of(e, 0), b.default_of(e, 0)), (1, 2));
                assert_eq!((a.value(0x5F0A, 1), b.value(0x5F0A, 1)), (Some(1), Some(2)));
            } else {
                assert_eq!(a.default_of(e, 7), b.default_of(e, 7), "{e:?}");
            }
        }
        assert_eq!(b.value(0x1800, 1), Some(0x182));
    }
}
