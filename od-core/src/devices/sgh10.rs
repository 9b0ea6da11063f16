//! SGH10 / SGH10L absolute wire-actuated encoder: the object dictionary of its manual
//! (SIKO art. no. 89013, status 098/22), every row, with the manual's types, access rights,
//! defaults and limits. 6003h and 6004h are listed in the manual's overview as "not used" and
//! are therefore absent (an SDO access gets 06020000h).
//!
//! The behaviour is the linear CiA 406 encoder of [`crate::encoder::linear`] with the SGH10's
//! measuring range and its EMCY FF12h "speed error".

use crate::abort::Abort;
use crate::context::{BusEvent, Context as Core, ResetKind};
use crate::device::{CanopenDevice, Device, Link};
use crate::devices::comm::{self, CanOpen, Identity, NodeIdAndBitrate, Pdo, Profile, Serial};
use crate::encoder::linear::{Entries, Linear, LinearSpec};
use crate::encoder::{Encoder, SensorFault, CYCLE_TIMER_LINK};
use crate::od::{Access::*, DataType::*, Entry, Group, Hook};
use crate::time::Instant;

/// Device-specific write hooks of the SGH10 (`Hook::Device(n)`): the linear encoders' ones.
pub use crate::encoder::linear::hooks;

const APP: Group = Group::App;
const fn dev(h: u8) -> Hook {
    Hook::Device(h)
}

/// Default node-ID ex works.
pub const DEFAULT_NODE_ID: u8 = 1;
/// Default 5F0Ah.02 bit-rate code (5 = 500 kbit/s).
pub const DEFAULT_BITRATE_CODE: u8 = 5;

/// Entries in the SGH10 dictionary.
pub const ENTRIES: usize = 96;

/// What the SGH10's communication profile (1000h-1FFFh) declares; [`comm`] writes the rows.
const PROFILE: Profile = Profile {
    device_type: 0x000A_0196,
    status_register: true,
    device_name: Some("SGH10"),
    hardware_version: Some("V100"),
    software_version: "V100",
    identity: Identity::siko(Serial::Factory(1)),
    heads: Const,
    canopen: Some(CanOpen {
        rpdos: &[],
        tpdos: &[Pdo::new(0xFE, &TPDO_MAPPING).event_timer(dev(hooks::CYCLE_TIMER)), Pdo::new(0x01, &TPDO_MAPPING)],
    }),
};
/// TPDO1 and TPDO2 both map the position (6020h.01) and the speed (6030h.01).
const TPDO_MAPPING: [u32; 2] = [0x6020_0120, 0x6030_0110];
/// 5F0Ah.
const NODE: NodeIdAndBitrate = NodeIdAndBitrate::new(DEFAULT_NODE_ID, (1, 127), DEFAULT_BITRATE_CODE, (1, 7));

static ROWS: [Entry; ENTRIES] = comm::join(&[
    comm::rows(&PROFILE).as_slice(),
    &[Entry::var(0x5000, "Diagnosis CAN bus error", Unsigned32, Ro, 0)],
    comm::node_id_and_bitrate(&NODE).as_slice(),
    &[
        Entry::var(0x6000, "Operating parameters", Unsigned16, Rw, 0x0004)
            .range(0x0004, 0x000C)
            .group(APP)
            .hook(dev(hooks::OPERATING_PARAMETERS)),
        Entry::var(0x6002, "Total measuring range in measuring units", Unsigned32, Rw, 10239).group(APP),
        Entry::record(0x6005, "Linear encoder measuring step settings", 2, Ro),
        Entry::member(0x6005, 1, "Position step setting", Unsigned32, Rw, 100_000).range(100_000, 100_000).group(APP),
        Entry::member(0x6005, 2, "Speed step setting", Unsigned32, Rw, 100).range(100, 100).group(APP),
        Entry::array(0x6010, "Preset value for multi-sensor devices", 1, Ro),
        Entry::member(0x6010, 1, "Calibration value", Integer32, Rw, 0)
            .range(-10239, 10239)
            .pdo()
            .hook(dev(hooks::CALIBRATE)),
        Entry::array(0x6020, "Position value for multi-sensor devices", 1, Ro),
        Entry::member(0x6020, 1, "Position value", Integer32, Ro, 0).pdo(),
        Entry::array(0x6030, "Speed value", 1, Ro),
        Entry::member(0x6030, 1, "Speed value channel 1", Integer16, Ro, 0).pdo(),
        Entry::var(0x6200, "Cyclic timer", Unsigned16, Rw, 0).group(APP).hook(dev(hooks::CYCLE_TIMER)),
        Entry::array(0x6400, "Area state register", 2, Ro),
        Entry::member(0x6400, 1, "Work area state channel 1", Unsigned8, Ro, 0),
        Entry::member(0x6400, 2, "Work area state channel 2", Unsigned8, Ro, 0),
        Entry::array(0x6401, "Work area low limit", 2, Ro),
        Entry::member(0x6401, 1, "Work area low limit channel 1", Integer32, Rw, -20478i32 as u32)
            .range(-20478, 30717)
            .group(APP)
            .hook(dev(hooks::WORK_AREA)),
        Entry::member(0x6401, 2, "Work area low limit channel 2", Integer32, Rw, -20478i32 as u32)
            .range(-20478, 30717)
            .group(APP)
            .hook(dev(hooks::WORK_AREA)),
        Entry::array(0x6402, "Work area high limit", 2, Ro),
        Entry::member(0x6402, 1, "Work area high limit channel 1", Integer32, Rw, 30717)
            .range(-20478, 30717)
            .group(APP)
            .hook(dev(hooks::WORK_AREA)),
        Entry::member(0x6402, 2, "Work area high limit channel 2", Integer32, Rw, 30717)
            .range(-20478, 30717)
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
        Entry::member(0x650A, 2, "Manufacturer minimum position value", Integer32, Ro, -20478i32 as u32),
        Entry::member(0x650A, 3, "Manufacturer maximum position value", Integer32, Ro, 30717),
        Entry::var(0x650B, "Serial number", Unsigned32, Ro, 0).group(Group::Factory),
        Entry::array(0x650C, "Offset values for multi-sensor devices", 1, Ro),
        Entry::member(0x650C, 1, "Offset value channel 1", Integer32, Ro, 0).group(APP),
    ],
]);

/// The SGH10 dictionary, sorted by (index, sub).
pub static TABLE: &[Entry] = &ROWS;

/// The SGH10's measuring range, speed error and timing.
pub const SPEC: LinearSpec = LinearSpec {
    // 6002h: 10239 steps of 0.1 mm; the calibration range is ±10239.
    max_steps: 10239,
    speed_error: true,
    integration_us: 100_000,
    sample_period_us: 1_000,
    entries: &ENTRIES_AT,
};

/// Where the linear encoder's objects sit in the table.
static ENTRIES_AT: Entries = Entries::of(&ROWS);

/// The product variants of the manual; it describes no difference in behaviour or dictionary.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Variant {
    /// SGH10.
    Sgh10,
    /// SGH10L.
    Sgh10L,
}

/// An SGH10 / SGH10L.
#[derive(Clone, Debug)]
pub struct Sgh10 {
    variant: Variant,
    linear: Linear,
}

impl Sgh10 {
    /// A device of `variant`, before its first sensor sample.
    pub const fn new(variant: Variant) -> Sgh10 {
        Sgh10 { variant, linear: Linear::new(SPEC) }
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

impl Device for Sgh10 {
    fn table(&self) -> &'static [Entry] {
        TABLE
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

impl CanopenDevice for Sgh10 {}

impl Encoder for Sgh10 {
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
        // 98 rows in the manual's object list; 6003h and 6004h are "not used".
        assert_eq!(TABLE.len(), 96);
        let od = Od::new(TABLE, DEFAULT_NODE_ID);
        assert_eq!(od.value(0x1000, 0), Some(0x000A_0196));
        assert_eq!(od.value(0x1018, 1), Some(0x195));
        assert_eq!(od.value(0x1014, 0), Some(0x81));
        assert_eq!(od.value(0x1800, 1), Some(0x181));
        assert_eq!(od.value(0x1801, 1), Some(0x281));
        assert_eq!(od.value(0x6401, 1), Some(-20478i32 as u32));
        assert!(od.pos(0x6003, 0).is_none() && od.pos(0x6004, 0).is_none());
    }
}
