//! SGH50 SDO scenarios: the manual's printed examples (digest 6.1) and the dictionary as the
//! manual prints it, read and written through the SDO server; the redundant second encoder's
//! restore. Moved to `tests/` when the SDO server is on this branch.

use od_core::devices::sgh50::{self, Channel, Sgh50, Variant};
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::encoder::{sdo_read, sdo_write, sdo_write_abort, value, Sensed, Sensor};

const SERIAL: u32 = 0x0012_D687;

fn sgh50(variant: Variant, um: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(um);
    let mut node = Node::new(Sgh50::new(variant), variant.default_node_id(), Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, SERIAL);
    let mut bus = Bus::new();
    bus.add(Sensed::new(node, sensor.clone()));
    let id = variant.default_node_id() as u16;
    bus.expect(0x700 + id, &[0x00]);
    bus.expect_silence();
    (bus, sensor)
}

#[test]
fn e1_calibrate_to_510_and_read_it_back() {
    let (mut bus, _) = sgh50(Variant::Single, 2_000_000);
    bus.send(Frame::std(0x601, &[0x23, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x10, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x10, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x43, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x20, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x43, 0x20, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6509, 0), 20_000 - 510);
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 4, 73840, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6010, 1, 4, (-73840i32) as u32, 0x0609_0030);
}

#[test]
fn e2_cycle_timer_then_1800h_05_reads_4500() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    bus.send(Frame::std(0x601, &[0x2B, 0x00, 0x62, 0x00, 0x94, 0x11, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x00, 0x62, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x00, 0x18, 0x05, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x4B, 0x00, 0x18, 0x05, 0x94, 0x11, 0x00, 0x00]);
}

#[test]
fn work_areas_raise_ff15h_and_ff16h() {
    let (mut bus, sensor) = sgh50(Variant::Single, 5_000_000);
    let before = sdo_write(&mut bus, 1, 0x6401, 1, 4, 60_000);
    assert_eq!(before.len(), 1);
    assert_eq!(before[0].payload(), &[0x15, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    let before = sdo_write(&mut bus, 1, 0x6402, 2, 4, 40_000);
    assert_eq!(before[0].payload(), &[0x16, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    assert_eq!(sdo_read(&mut bus, 1, 0x6400, 1), 0x05);
    assert_eq!(sdo_read(&mut bus, 1, 0x6400, 2), 0x03);
    assert_eq!(sdo_read(&mut bus, 1, 0x6503, 0), 0x3000);
    sensor.set(4_000_000);
    bus.advance(1);
    bus.expect(0x081, &[0x00, 0x00, 0x81, 0, 0, 0, 0, 0]);
    sdo_write_abort(&mut bus, 1, 0x6401, 1, 4, (-147679i32) as u32, 0x0609_0030);
    sdo_write_abort(&mut bus, 1, 0x6402, 1, 4, 221518, 0x0609_0030);
}

#[test]
fn bus_termination_5f09h_is_0_or_1() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    assert_eq!(sdo_read(&mut bus, 1, 0x5F09, 0), 0);
    sdo_write(&mut bus, 1, 0x5F09, 0, 1, 1);
    assert_eq!(sdo_read(&mut bus, 1, 0x5F09, 0), 1);
    sdo_write_abort(&mut bus, 1, 0x5F09, 0, 1, 2, 0x0609_0030);
}

#[test]
fn identity_and_profile_objects_read_as_printed() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    for (index, sub, v) in [
        (0x1000, 0, 0x000A_0196),
        (0x1018, 1, 0x195),
        (0x1018, 2, 0xFFFF_FFFF),
        (0x1018, 3, 0xFFFF_FFFF),
        (0x1018, 4, SERIAL),
        (0x650B, 0, SERIAL),
        (0x6002, 0, 73840),
        (0x6005, 1, 100_000),
        (0x6005, 2, 100),
        (0x6500, 0, 0x0004),
        (0x6501, 0, 100_000),
        (0x6502, 0, 1),
        (0x6504, 0, 0x3001),
        (0x6506, 0, 0),
        (0x6507, 0, 0x0100_0302),
        (0x6508, 0, 0xFFFF_FFFF),
        (0x650A, 2, 0xFFFD_BF22),
        (0x650A, 3, 0x0003_614D),
    ] {
        assert_eq!(sdo_read(&mut bus, 1, index, sub), v, "{index:04X}h.{sub:02X}");
    }
    sdo_write_abort(&mut bus, 1, 0x1800, 4, 1, 0, 0x0609_0011);
    sdo_write_abort(&mut bus, 1, 0x1801, 6, 1, 0, 0x0609_0011);
    sdo_write_abort(&mut bus, 1, 0x6003, 0, 4, 0, 0x0602_0000);
    sdo_write_abort(&mut bus, 1, 0x1800, 2, 1, 0xFC, 0x0609_0030);
}

#[test]
fn every_entry_reads_its_declared_default_at_power_on() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    for e in sgh50::TABLE {
        let string = matches!(e.default(), od_core::od::Default::Str(_));
        if !e.access.readable() || string || e.size() > 4 || e.size() == 0 || (e.index == 0x1003 && e.sub > 0) {
            continue;
        }
        let v = sdo_read(&mut bus, 1, e.index, e.sub);
        if !matches!((e.index, e.sub), (0x1018, 4) | (0x650B, 0)) {
            assert_eq!(v, e.default_value(1), "{:04X}h.{:02X} {}", e.index, e.sub, e.name());
        }
    }
}

#[test]
fn restore_on_the_second_encoder_keeps_node_id_2() {
    let (mut bus, _) = sgh50(Variant::Redundant(Channel::Second), 0);
    sdo_write(&mut bus, 2, 0x5F0A, 1, 1, 9);
    bus.send(Frame::std(0x000, &[0x82, 0x02]));
    bus.expect(0x709, &[0x00]);
    sdo_write(&mut bus, 9, 0x1011, 4, 4, 0x6461_6F6C);
    bus.send(Frame::std(0x000, &[0x81, 0x09]));
    bus.expect(0x702, &[0x00]);
    assert_eq!(sdo_read(&mut bus, 2, 0x5F0A, 1), 2);
}

#[test]
fn s1_s2_s4_store_all_and_read_1010h() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    bus.send(Frame::std(0x601, &[0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]));
    bus.expect(0x581, &[0x60, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x43, 0x10, 0x10, 0x01, 0x01, 0x00, 0x00, 0x00]);
}

#[test]
fn n7_heartbeat_of_the_sgh50() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    sdo_write(&mut bus, 1, 0x1017, 0, 2, 100);
    bus.advance(100);
    bus.expect(0x701, &[0x7F]);
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.advance(100);
    bus.expect(0x701, &[0x05]);
}

/// 5F09h switches the internal bus termination at once (D-SGH50-5): the board follows
/// `sgh50::bus_termination`. Unsaved, it is off again after a Reset Node; saved, it stays on.
#[test]
fn bus_termination_follows_5f09h() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    assert!(!sgh50::bus_termination(bus.station(0).core()));
    sdo_write(&mut bus, 1, 0x5F09, 0, 1, 1);
    assert!(sgh50::bus_termination(bus.station(0).core()));
    sdo_write_abort(&mut bus, 1, 0x5F09, 0, 1, 2, 0x0609_0030);
    assert!(sgh50::bus_termination(bus.station(0).core()));
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    assert!(!sgh50::bus_termination(bus.station(0).core()), "not saved: off after Reset Node");
    sdo_write(&mut bus, 1, 0x5F09, 0, 1, 1);
    sdo_write(&mut bus, 1, 0x1010, 4, 4, 0x6576_6173);
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    assert!(sgh50::bus_termination(bus.station(0).core()), "saved: on after Reset Node");
    sdo_write(&mut bus, 1, 0x5F09, 0, 1, 0);
    assert!(!sgh50::bus_termination(bus.station(0).core()));
}

/// SGH50 A4 (D-SDO-4): the 5 bytes of "SGH50" come in one last segment whose command byte is
/// 05h (n = 2 unused bytes, c = 1), as CiA 301 encodes it, not the manual's 03h; the printed
/// index bytes in the segment request (E3c) are ignored.
#[test]
fn a4_device_name_last_segment_is_05h() {
    let (mut bus, _) = sgh50(Variant::Single, 0);
    bus.send(Frame::std(0x601, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]));
    bus.expect(0x581, &[0x41, 0x08, 0x10, 0x00, 0x05, 0x00, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0]));
    bus.expect(0x581, &[0x05, b'S', b'G', b'H', b'5', b'0', 0x00, 0x00]);
}

/// SGH50 A3: TPDO1's COB-ID is 180h + node-ID (Table 2), on either channel.
#[test]
fn a3_tpdo1_cob_id_is_180h_plus_node_id() {
    for variant in [Variant::Single, Variant::Redundant(Channel::Second)] {
        let (mut bus, _) = sgh50(variant, 0);
        let id = variant.default_node_id();
        let answer = sdo_read(&mut bus, id, 0x1800, 1);
        assert_eq!(answer, 0x180 + id as u32);
    }
}
