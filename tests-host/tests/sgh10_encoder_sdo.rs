//! SGH10 encoder scenarios on the virtual bus: the manual's examples (digest section 6.1) and
//! the derived vectors of section 6.2 for position, calibration, speed, work areas, EMCYs and
//! CAN diagnosis, byte for byte, plus failure cases and property tests of the position
//! pipeline over the whole value ranges.
//!
//! The sensor reads the wire extension in µm; 6005h.01 = 100000 nm makes a step 0.1 mm, so
//! 51 000 µm is the position 510 of the manual's examples.

use od_core::devices::sgh10::{self, Sgh10, Variant};
use od_core::encoder::SensorFault;
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::encoder::{sdo_read, sdo_write, sdo_write_abort, value, Sensed, Sensor};

const SERIAL: u32 = 0x0001_E240;

/// A bus with an SGH10 (node 1, 500 kbit/s) whose wire is out `um` µm, after its boot-up.
fn sgh10(um: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(um);
    let mut node = Node::new(Sgh10::new(Variant::Sgh10), 1, Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, SERIAL);
    let mut bus = Bus::new();
    bus.add(Sensed::new(node, sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    (bus, sensor)
}

fn od(bus: &mut Bus, index: u16, sub: u8) -> i64 {
    value(bus.station(0).core(), index, sub)
}

fn emcy(code: u16, register: u8) -> [u8; 8] {
    let c = code.to_le_bytes();
    [c[0], c[1], register, 0, 0, 0, 0, 0]
}

#[track_caller]
fn frames_are(frames: &[Frame], expected: &[(u16, [u8; 8])]) {
    let got: Vec<(od_core::CanId, Vec<u8>)> = frames.iter().map(|f| (f.id, f.payload().to_vec())).collect();
    let want: Vec<(od_core::CanId, Vec<u8>)> =
        expected.iter().map(|(id, d)| (od_core::CanId::Std(*id), d.to_vec())).collect();
    assert_eq!(got, want);
}

#[test]
fn e1_calibration_value_reads_back_as_printed() {
    let (mut bus, _) = sgh10(123_400);
    assert_eq!(od(&mut bus, 0x6020, 1), 1234);
    // Calibrate to 510, then the manual's E1 read.
    bus.send(Frame::std(0x601, &[0x23, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x10, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x10, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x43, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
    // Position value = 0 + calibration value; the offset is the encoder value minus it.
    bus.send(Frame::std(0x601, &[0x40, 0x20, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x43, 0x20, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
    assert_eq!(od(&mut bus, 0x6509, 0), 1234 - 510);
    assert_eq!(od(&mut bus, 0x650C, 1), 1234 - 510);
    bus.expect_silence();
}

#[test]
fn after_calibration_the_position_follows_the_wire() {
    let (mut bus, sensor) = sgh10(123_400);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, (-100i32) as u32);
    assert_eq!(od(&mut bus, 0x6020, 1), -100);
    sensor.set(133_400);
    bus.advance(1);
    // Position value = measured value (10 mm further out) + calibration value.
    assert_eq!(od(&mut bus, 0x6020, 1), 0);
    sensor.set(0);
    bus.advance(1);
    assert_eq!(od(&mut bus, 0x6020, 1), -1334);
}

#[test]
fn calibration_limits_and_missing_reading() {
    let (mut bus, sensor) = sgh10(51_000);
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 4, 10240, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 4, (-10240i32) as u32, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 2, 5, 0x0607_0013);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, 10239);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, (-10239i32) as u32);
    // With no valid reading there is nothing to calibrate: 08000024h "no data available".
    sensor.fail(SensorFault::Diagnosis);
    bus.advance(1);
    bus.drain();
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 4, 0, 0x0800_0024);
    assert_eq!(od(&mut bus, 0x6020, 1), -10239, "the last valid position stays");
}

#[test]
fn e2_cycle_timer_is_the_tpdo1_event_timer() {
    let (mut bus, _) = sgh10(51_000);
    bus.send(Frame::std(0x601, &[0x2B, 0x00, 0x62, 0x00, 0x94, 0x11, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x00, 0x62, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x00, 0x18, 0x05, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x4B, 0x00, 0x18, 0x05, 0x94, 0x11, 0x00, 0x00]);
    // And the other way round.
    sdo_write(&mut bus, 1, 0x1800, 5, 2, 100);
    assert_eq!(sdo_read(&mut bus, 1, 0x6200, 0), 100);
}

#[test]
fn direction_change_mirrors_the_position_until_calibrated_again() {
    let (mut bus, sensor) = sgh10(123_400);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, 510);
    sdo_write(&mut bus, 1, 0x6000, 0, 2, 0x000C);
    assert_eq!(sdo_read(&mut bus, 1, 0x6500, 0), 0x000C);
    assert_eq!(od(&mut bus, 0x6020, 1), -510, "mirrored about zero");
    // Descending: pulling the wire out lowers the position.
    sensor.set(124_400);
    bus.advance(1);
    assert_eq!(od(&mut bus, 0x6020, 1), -520);
    // The manual: after the change a calibration value must be sent anew.
    sdo_write(&mut bus, 1, 0x6010, 1, 4, 510);
    assert_eq!(od(&mut bus, 0x6020, 1), 510);
    sensor.set(125_400);
    bus.advance(1);
    assert_eq!(od(&mut bus, 0x6020, 1), 500);
    sdo_write(&mut bus, 1, 0x6000, 0, 2, 0x0004);
    assert_eq!(sdo_read(&mut bus, 1, 0x6500, 0), 0x0004);
    assert_eq!(od(&mut bus, 0x6020, 1), -500);
    // Scaling cannot be switched off; other bits are not used.
    sdo_write_abort(&mut bus, 1, 0x6000, 0, 2, 0x0000, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6000, 0, 2, 0x0008, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6000, 0, 2, 0x0005, 0x0609_0030);
    assert_eq!(sdo_read(&mut bus, 1, 0x6000, 0), 0x0004);
}

#[test]
fn speed_in_millimetres_per_second_over_100_ms() {
    let (mut bus, sensor) = sgh10(100_000);
    sensor.move_at(25_000);
    bus.advance(250);
    bus.send(Frame::std(0x601, &[0x40, 0x30, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x4B, 0x30, 0x60, 0x01, 0x19, 0x00, 0x00, 0x00]);
    // −5 mm/s (digest 6.2: bytes FB FF).
    sensor.move_at(-5_000);
    bus.advance(250);
    bus.send(Frame::std(0x601, &[0x40, 0x30, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x4B, 0x30, 0x60, 0x01, 0xFB, 0xFF, 0x00, 0x00]);
    // The sign follows the counting direction.
    sdo_write(&mut bus, 1, 0x6000, 0, 2, 0x000C);
    bus.advance(250);
    assert_eq!(od(&mut bus, 0x6030, 1), 5);
    sensor.move_at(0);
    bus.advance(250);
    assert_eq!(od(&mut bus, 0x6030, 1), 0);
}

#[test]
fn work_area_1_violation_raises_ff15h_once_and_clears_with_0000h() {
    let (mut bus, sensor) = sgh10(51_000);
    bus.send(Frame::std(0x601, &[0x2B, 0x17, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x17, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // Low limit above the position: below work area 1.
    let before = sdo_write(&mut bus, 1, 0x6401, 1, 4, 600);
    frames_are(&before, &[(0x081, emcy(0xFF15, 0x81))]);
    assert_eq!(od(&mut bus, 0x6400, 1), 0x05, "outside, below the low limit");
    assert_eq!(od(&mut bus, 0x6400, 2), 0x00);
    assert_eq!(sdo_read(&mut bus, 1, 0x6503, 0), 0x1000);
    assert_eq!(sdo_read(&mut bus, 1, 0x1001, 0), 0x81);
    // Only once per error event, however many samples see it.
    bus.advance(500);
    bus.expect_silence();
    // The wire moves into the area: 0000h with the remaining errors (none).
    sensor.set(61_000);
    bus.advance(1);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    assert_eq!(od(&mut bus, 0x6400, 1), 0x00);
    assert_eq!(od(&mut bus, 0x6503, 0), 0);
    // A limit equal to the position is inside.
    assert!(sdo_write(&mut bus, 1, 0x6402, 1, 4, 610).is_empty());
    assert_eq!(sdo_read(&mut bus, 1, 0x1003, 0), 1);
    assert_eq!(sdo_read(&mut bus, 1, 0x1003, 1), 0xFF15);
}

#[test]
fn work_area_2_above_high_limit_raises_ff16h() {
    let (mut bus, sensor) = sgh10(51_000);
    let before = sdo_write(&mut bus, 1, 0x6402, 2, 4, 500);
    frames_are(&before, &[(0x081, emcy(0xFF16, 0x81))]);
    assert_eq!(od(&mut bus, 0x6400, 2), 0x03, "outside, above the high limit");
    assert_eq!(od(&mut bus, 0x6503, 0), 0x2000);
    // Both areas at once: the register keeps the remaining error after one clears.
    sdo_write(&mut bus, 1, 0x6401, 1, 4, 600);
    assert_eq!(od(&mut bus, 0x6503, 0), 0x3000);
    sensor.set(40_000);
    bus.advance(1);
    // Area 2 clears (400 <= 500), area 1 stays (400 < 600).
    bus.expect(0x081, &emcy(0x0000, 0x81));
    assert_eq!(od(&mut bus, 0x6503, 0), 0x1000);
    // Limits outside the transferable range are refused.
    sdo_write_abort(&mut bus, 1, 0x6401, 1, 4, (-20479i32) as u32, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6402, 2, 4, 30718, 0x0609_0030);
}

#[test]
fn profile_identity_objects_read_as_the_manual_prints_them() {
    let (mut bus, _) = sgh10(51_000);
    for (index, sub, v) in [
        (0x1000, 0, 0x000A_0196),
        (0x6002, 0, 10239),
        (0x6005, 1, 100_000),
        (0x6005, 2, 100),
        (0x6500, 0, 0x0004),
        (0x6501, 0, 100_000),
        (0x6502, 0, 1),
        (0x6504, 0, 0x3001),
        (0x6505, 0, 0),
        (0x6506, 0, 0),
        (0x6507, 0, 0x0100_0302),
        (0x6508, 0, 0xFFFF_FFFF),
        (0x650A, 1, 0),
        (0x650A, 2, 0xFFFF_B002),
        (0x650A, 3, 0x0000_77FD),
        (0x650B, 0, SERIAL),
        (0x1018, 4, SERIAL),
        // A12: the printed "FFFFFFFh" is one F short.
        (0x1018, 2, 0xFFFF_FFFF),
        (0x1018, 3, 0xFFFF_FFFF),
        (0x6401, 1, 0xFFFF_B002),
        (0x6402, 2, 0x0000_77FD),
    ] {
        assert_eq!(sdo_read(&mut bus, 1, index, sub), v, "{index:04X}h.{sub:02X}");
    }
    sdo_write_abort(&mut bus, 1, 0x6005, 1, 4, 50_000, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6005, 2, 4, 1000, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6020, 1, 4, 0, 0x0601_0002);
    sdo_write_abort(&mut bus, 1, 0x6509, 0, 4, 0, 0x0601_0002);
    sdo_write_abort(&mut bus, 1, 0x6003, 0, 4, 0, 0x0602_0000);
    sdo_write_abort(&mut bus, 1, 0x6004, 0, 4, 0, 0x0602_0000);
}

#[test]
fn every_entry_reads_its_declared_default_at_power_on() {
    let (mut bus, _) = sgh10(0);
    for e in sgh10::TABLE {
        // 1003h entries above the error count answer 08000024h; strings are segmented.
        let string = matches!(e.default(), od_core::od::Default::Str(_));
        if !e.access.readable() || string || e.size() > 4 || e.size() == 0 || (e.index == 0x1003 && e.sub > 0) {
            continue;
        }
        let live = matches!((e.index, e.sub), (0x1018, 4) | (0x650B, 0));
        let v = sdo_read(&mut bus, 1, e.index, e.sub);
        if !live {
            assert_eq!(v, e.default_value(1), "{:04X}h.{:02X} {}", e.index, e.sub, e.name());
        }
    }
}

#[test]
fn calibration_survives_a_power_cycle_in_the_offset_not_in_6010h() {
    use od_core::storage::{identity, ParamFlash, Region};
    use tests_host::flash::RamFlash;
    let sensor = Sensor::new(123_400);
    let s = sensor.clone();
    let params = ParamFlash::new(RamFlash::new(2), Region { offset: 0, pages: 2 }, identity(sgh10::TABLE));
    let mut bus = Bus::new();
    bus.add_with_flash(params, move |loaded| Sensed::new(Node::boot(Sgh10::new(Variant::Sgh10L), loaded), s.clone()));
    bus.expect(0x701, &[0x00]);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, 510);
    sdo_write(&mut bus, 1, 0x6000, 0, 2, 0x000C);
    sdo_write(&mut bus, 1, 0x6010, 1, 4, 700);
    sdo_write(&mut bus, 1, 0x1010, 3, 4, 0x6576_6173);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    assert_eq!(sdo_read(&mut bus, 1, 0x6010, 1), 0, "6010h.01 is not stored");
    assert_eq!(sdo_read(&mut bus, 1, 0x6020, 1), 700);
    assert_eq!(sdo_read(&mut bus, 1, 0x6500, 0), 0x000C);
    sensor.set(124_400);
    bus.advance(1);
    assert_eq!(sdo_read(&mut bus, 1, 0x6020, 1), 690);
    // Restoring the application parameters forgets the calibration at the next reset.
    sdo_write(&mut bus, 1, 0x1011, 3, 4, 0x6461_6F6C);
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    assert_eq!(sdo_read(&mut bus, 1, 0x6509, 0), 0);
    assert_eq!(sdo_read(&mut bus, 1, 0x6020, 1), 1244);
}

#[test]
fn node_id_change_via_5f0ah_takes_effect_after_reset() {
    let (mut bus, _) = sgh10(51_000);
    bus.send(Frame::std(0x601, &[0x2F, 0x0A, 0x5F, 0x01, 0x05, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x0A, 0x5F, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65]));
    bus.expect(0x581, &[0x60, 0x10, 0x10, 0x04, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x705, &[0x00]);
    // The encoder works on under its new node-ID; its EMCY follows it.
    let before = sdo_write(&mut bus, 5, 0x6401, 1, 4, 600);
    frames_are(&before, &[(0x085, emcy(0xFF15, 0x81))]);
}
