//! WV5800M SDO scenarios: the manual's printed examples (digest 6.1 E1-E3), the derived vectors
//! of digest 6.3 and the dictionary's refusals, byte for byte, node-ID 1. Moved to `tests/` when
//! the SDO server is on this branch. They pass against a throwaway expedited/segmented SDO
//! server (checked on the wv5800m branch, not committed).

use od_core::devices::wv5800m::{Model, Turns, Variant, Wv5800m};
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::encoder::{sdo_read, sdo_write, sdo_write_abort, value, Sensed, Sensor};

const SERIAL: u32 = 0x0012_D687;
const MT12: Variant = Variant { model: Model::Wv, turns: Turns::Multi12 };

fn wv(variant: Variant, raw: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(raw);
    let mut node = Node::new(Wv5800m::new(variant), 1, Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, SERIAL);
    let mut bus = Bus::new();
    bus.add(Sensed::new(node, sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    (bus, sensor)
}

#[track_caller]
fn exchange(bus: &mut Bus, request: [u8; 8], answer: [u8; 8]) {
    bus.send(Frame::std(0x601, &request));
    bus.expect(0x581, &answer);
}

#[test]
fn e1_read_the_calibration_value_510() {
    let (mut bus, _) = wv(MT12, 1000);
    exchange(&mut bus, [0x23, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00], [0x60, 0x03, 0x60, 0x00, 0, 0, 0, 0]);
    // E1, with the printed "X" bytes as 00.
    exchange(&mut bus, [0x40, 0x03, 0x60, 0x00, 0, 0, 0, 0], [0x43, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00]);
    // 6003h is a summand until 2002h zeroes the measured value (digest 6.3).
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 1510);
    exchange(&mut bus, [0x2F, 0x02, 0x20, 0x00, 0x01, 0, 0, 0], [0x60, 0x02, 0x20, 0x00, 0, 0, 0, 0]);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 510);
    assert_eq!(sdo_read(&mut bus, 1, 0x6509, 0), 1000);
}

#[test]
fn e2_cycle_timer_4500_is_also_1800h_05() {
    let (mut bus, _) = wv(MT12, 0);
    exchange(&mut bus, [0x2B, 0x00, 0x62, 0x00, 0x94, 0x11, 0x00, 0x00], [0x60, 0x00, 0x62, 0x00, 0, 0, 0, 0]);
    exchange(&mut bus, [0x40, 0x00, 0x18, 0x05, 0, 0, 0, 0], [0x4B, 0x00, 0x18, 0x05, 0x94, 0x11, 0x00, 0x00]);
}

#[test]
fn e3_segmented_read_of_the_device_name() {
    for (model, name) in [(Model::Wv, *b"WV5800M"), (Model::Wh, *b"WH5800M")] {
        let (mut bus, _) = wv(Variant { model, turns: Turns::Multi4 }, 0);
        exchange(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0], [0x41, 0x08, 0x10, 0x00, 0x07, 0x00, 0x00, 0x00]);
        // The printed segment request carries index and sub-index; they are ignored.
        let mut seg = [0x01; 8];
        seg[1..].copy_from_slice(&name);
        exchange(&mut bus, [0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0], seg);
        bus.expect_silence();
    }
}

#[test]
fn digest_6_3_derived_vectors() {
    let (mut bus, _) = wv(MT12, 0);
    exchange(&mut bus, [0x40, 0x10, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x10, 0x10, 0x01, 0x01, 0, 0, 0]);
    exchange(&mut bus, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x02, 0x00]);
    exchange(&mut bus, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0x00, 0x00]);
    exchange(&mut bus, [0x40, 0x09, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x09, 0x10, 0x00, 0x56, 0x30, 0x30, 0x31]);
    exchange(&mut bus, [0x2F, 0x02, 0x20, 0x00, 0x01, 0, 0, 0], [0x60, 0x02, 0x20, 0x00, 0, 0, 0, 0]);
    exchange(&mut bus, [0x40, 0x01, 0x60, 0x00, 0, 0, 0, 0], [0x43, 0x01, 0x60, 0x00, 0x00, 0x40, 0x00, 0x00]);
    exchange(&mut bus, [0x40, 0x00, 0x60, 0x00, 0, 0, 0, 0], [0x4B, 0x00, 0x60, 0x00, 0x04, 0x00, 0x00, 0x00]);
    exchange(&mut bus, [0x40, 0x0A, 0x5F, 0x02, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x02, 0x05, 0x00, 0x00, 0x00]);
    exchange(&mut bus, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    exchange(&mut bus, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64], [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
    // Singleturn device type.
    let (mut bus, _) = wv(Variant { model: Model::Wh, turns: Turns::Single }, 0);
    exchange(&mut bus, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00]);
}

#[test]
fn refusals() {
    let (mut bus, _) = wv(MT12, 0);
    // Digest 6.2 "SDO abort": write to 6004h.
    exchange(&mut bus, [0x23, 0x04, 0x60, 0x00, 0, 0, 0, 0], [0x80, 0x04, 0x60, 0x00, 0x02, 0x00, 0x01, 0x06]);
    // 2002h is write-only.
    exchange(&mut bus, [0x40, 0x02, 0x20, 0x00, 0, 0, 0, 0], [0x80, 0x02, 0x20, 0x00, 0x01, 0x00, 0x01, 0x06]);
    // 1800h sub 4 and 6 do not exist.
    exchange(&mut bus, [0x40, 0x00, 0x18, 0x04, 0, 0, 0, 0], [0x80, 0x00, 0x18, 0x04, 0x11, 0x00, 0x09, 0x06]);
    exchange(&mut bus, [0x40, 0x01, 0x18, 0x06, 0, 0, 0, 0], [0x80, 0x01, 0x18, 0x06, 0x11, 0x00, 0x09, 0x06]);
    // 6002h follows 6001h only.
    sdo_write_abort(&mut bus, 1, 0x6002, 0, 4, 1000, 0x0609_0030);
    sdo_write(&mut bus, 1, 0x6001, 0, 4, 1000);
    assert_eq!(sdo_read(&mut bus, 1, 0x6002, 0), 4_096_000);
    assert_eq!(sdo_read(&mut bus, 1, 0x650A, 3), 4_095_999);
    sdo_write(&mut bus, 1, 0x6002, 0, 4, 4_096_000);
    sdo_write_abort(&mut bus, 1, 0x6003, 0, 4, 4_096_000, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6000, 0, 2, 0x0000, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6031, 2, 2, 200, 0x0601_0002);
    sdo_write_abort(&mut bus, 1, 0x6031, 1, 1, 1, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x5F0A, 1, 1, 0, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x5F0A, 2, 1, 8, 0x0609_0030);
}

/// A 12-bit multiturn WV5800M whose parameters live in `flash` and whose sensor is `sensor`.
fn wv_with_flash(flash: tests_host::flash::RamFlash, sensor: &Sensor) -> Bus {
    use od_core::storage::{identity, ParamFlash, Region};
    let table = od_core::devices::wv5800m::table_of(MT12);
    let params = ParamFlash::new(flash, Region { offset: 0, pages: 2 }, identity(table));
    let mut bus = Bus::new();
    let sensor = sensor.clone();
    bus.add_with_flash(params, move |loaded| Sensed::new(Node::boot(Wv5800m::new(MT12), loaded), sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus
}

#[test]
fn calibration_survives_a_power_cycle_only_when_saved() {
    let sensor = Sensor::new(40_000);
    let mut bus = wv_with_flash(tests_host::flash::RamFlash::new(2), &sensor);
    bus.advance(1);
    sdo_write(&mut bus, 1, 0x6003, 0, 4, 510);
    sdo_write(&mut bus, 1, 0x2002, 0, 1, 1);
    assert_eq!(sdo_read(&mut bus, 1, 0x6004, 0), 510);
    // Not saved: a power cycle forgets it.
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    bus.advance(1);
    assert_eq!(sdo_read(&mut bus, 1, 0x6004, 0), 40_000);
    sdo_write(&mut bus, 1, 0x6003, 0, 4, 510);
    sdo_write(&mut bus, 1, 0x2002, 0, 1, 1);
    exchange(&mut bus, [0x23, 0x10, 0x10, 0x03, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x03, 0, 0, 0, 0]);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    sensor.set(40_100);
    bus.advance(1);
    assert_eq!(sdo_read(&mut bus, 1, 0x6004, 0), 610);
    assert_eq!(sdo_read(&mut bus, 1, 0x6509, 0), 40_000);
    // Restore the application defaults and reset: the calibration is gone.
    exchange(&mut bus, [0x23, 0x11, 0x10, 0x03, 0x6C, 0x6F, 0x61, 0x64], [0x60, 0x11, 0x10, 0x03, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    assert_eq!(sdo_read(&mut bus, 1, 0x6004, 0), 40_100);
    assert_eq!(sdo_read(&mut bus, 1, 0x6509, 0), 0);
}

/// 2002h = 0, its printed default, is accepted and calibrates nothing (D-WV-4): a configuration
/// tool that writes an EDS's DefaultValue back gets no abort and the position stays.
#[test]
fn calibrate_0_is_accepted_and_changes_nothing() {
    let (mut bus, _) = wv(MT12, 1000);
    let before = value(bus.station(0).core(), 0x6004, 0);
    let calibration = value(bus.station(0).core(), 0x6509, 0);
    sdo_write(&mut bus, 1, 0x2002, 0, 1, 0);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), before);
    assert_eq!(value(bus.station(0).core(), 0x6509, 0), calibration);
    sdo_write_abort(&mut bus, 1, 0x2002, 0, 1, 2, 0x0609_0030);
    sdo_write(&mut bus, 1, 0x2002, 0, 1, 1);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 0);
}

/// WV5800M 19, 20 (D-SDO-4): "WV5800M" (7 bytes) comes in one last segment with command byte
/// 01h (n = 0, c = 1), as the manual's example and CiA 301 have it; a segment request that
/// carries index and sub-index (the manual's example) is answered alike. 1018h sub 2 and 3 read
/// FFFFFFFFh (WV5800M 14: the printed "FFFFFFFh" is one F short).
#[test]
fn device_name_segment_and_identity() {
    let (mut bus, _) = wv(MT12, 1000);
    exchange(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0], [0x41, 0x08, 0x10, 0x00, 0x07, 0x00, 0x00, 0x00]);
    exchange(&mut bus, [0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0], [0x01, b'W', b'V', b'5', b'8', b'0', b'0', b'M']);
    assert_eq!(sdo_read(&mut bus, 1, 0x1018, 2), 0xFFFF_FFFF);
    assert_eq!(sdo_read(&mut bus, 1, 0x1018, 3), 0xFFFF_FFFF);
}
