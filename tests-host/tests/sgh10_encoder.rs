//! SGH10 encoder on the virtual bus: position, sensor faults, CAN controller events and their
//! EMCYs (digest 6.2 "EMCY"), the 5000h diagnosis; and property tests of the position pipeline
//! over the whole value ranges, on the device itself (scaling, calibration round trip,
//! direction change, work areas). The SDO examples are in `sgh10_encoder_sdo.rs`. The sensor
//! reads the wire extension in µm; 6005h.01 = 100000 nm makes a step 0.1 mm, so 51 000 µm is the
//! position 510 of the manual's examples.

use od_core::devices::sgh10::{Sgh10, Variant};
use od_core::encoder::SensorFault;
use od_core::node::{BusEvent, CanError};
use od_core::{Bitrate, Frame, Instant, Node};
use proptest::prelude::*;
use tests_host::bus::Bus;
use tests_host::encoder::{direct_write, value, Sensed, Sensor};

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

const SERIAL: u32 = 0x0001_E240;

fn od(bus: &mut Bus, index: u16, sub: u8) -> i64 {
    value(bus.station(0).core(), index, sub)
}

fn emcy(code: u16, register: u8) -> [u8; 8] {
    let c = code.to_le_bytes();
    [c[0], c[1], register, 0, 0, 0, 0, 0]
}

#[test]
fn sensor_fault_raises_ff05h_alone() {
    // FF12h "speed error" is a speed 6030h.01 cannot represent, not a sensor fault
    // (D-SGH10-8; `issue13_core.rs` has the saturation case).
    let (mut bus, sensor) = sgh10(51_000);
    bus.advance(200);
    sensor.fail(SensorFault::Diagnosis);
    bus.advance(1);
    bus.expect(0x081, &emcy(0xFF05, 0x81));
    bus.expect_silence();
    assert_eq!(od(&mut bus, 0x6503, 0), 0x0001);
    assert_eq!(od(&mut bus, 0x6030, 1), 0);
    bus.advance(100);
    bus.expect_silence();
    sensor.heal();
    bus.advance(1);
    // The position is valid again at once; the speed after a whole integration time.
    bus.expect(0x081, &emcy(0x0000, 0x00));
    assert_eq!(od(&mut bus, 0x6503, 0), 0);
    bus.advance(100);
    bus.expect_silence();
    assert_eq!(od(&mut bus, 0x1003, 0), 1);
    assert_eq!(od(&mut bus, 0x1003, 1), 0xFF05);
}

#[test]
fn a_reading_beyond_the_measuring_range_is_a_position_error() {
    let (mut bus, sensor) = sgh10(51_000);
    sensor.set(1_024_000);
    bus.advance(1);
    bus.expect(0x081, &emcy(0xFF05, 0x81));
    bus.expect_silence();
    assert_eq!(od(&mut bus, 0x6503, 0), 1);
    assert_eq!(od(&mut bus, 0x6020, 1), 510, "the last valid position stays");
}

#[test]
fn no_emcy_in_stopped_but_the_register_and_history_record_it() {
    let (mut bus, sensor) = sgh10(51_000);
    bus.send(Frame::std(0x000, &[0x02, 0x01]));
    sensor.fail(SensorFault::NoResponse);
    bus.advance(10);
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x80, 0x01]));
    bus.expect_silence();
    assert_eq!(od(&mut bus, 0x1001, 0), 0x81);
    assert_eq!(od(&mut bus, 0x1003, 0), 1);
    assert_eq!(od(&mut bus, 0x6503, 0), 1);
    sensor.heal();
    bus.advance(1);
    bus.expect(0x081, &emcy(0x0000, 0x00));
}

#[test]
fn can_controller_events_raise_8120h_and_8140h() {
    let (mut bus, sensor) = sgh10(51_000);
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    bus.expect(0x081, &[0x20, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    bus.expect_silence();
    sensor.bus_event(BusEvent::ErrorActive);
    bus.advance(0);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    // Bus-off: nothing can be sent; the recovery is reported, and its cause is gone.
    sensor.bus_event(BusEvent::ErrorPassive);
    sensor.bus_event(BusEvent::BusOff);
    bus.advance(0);
    bus.expect(0x081, &emcy(0x8120, 0x11));
    sensor.bus_event(BusEvent::BusOffRecovered);
    bus.advance(0);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    bus.expect(0x081, &[0x40, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    bus.expect_silence();
    assert_eq!(od(&mut bus, 0x1003, 1), 0x8140);
}

#[test]
fn diagnosis_5000h_ranks_the_error_kinds_and_1002h_shows_the_counters() {
    let (mut bus, sensor) = sgh10(51_000);
    assert_eq!(od(&mut bus, 0x5000, 0), 0);
    for e in [CanError::Stuff, CanError::Stuff, CanError::Crc, CanError::Acknowledge, CanError::Stuff, CanError::Crc] {
        sensor.bus_event(BusEvent::ProtocolError(e));
    }
    sensor.bus_event(BusEvent::ErrorCounters { rx: 9, tx: 130 });
    bus.advance(0);
    // Stuff most frequent (4), CRC next (3), acknowledge (2), form never (0).
    assert_eq!(od(&mut bus, 0x5000, 0), 0x0403_0002);
    assert_eq!(od(&mut bus, 0x1002, 0), 0x0000_8209);
    // The ranking belongs to the CAN communication: a reset clears it.
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    assert_eq!(od(&mut bus, 0x5000, 0), 0);
}

#[test]
fn position_is_the_wire_in_tenths_of_a_millimetre() {
    let (mut bus, sensor) = sgh10(51_000);
    assert_eq!(od(&mut bus, 0x6020, 1), 510);
    sensor.set(51_099);
    bus.advance(1);
    assert_eq!(od(&mut bus, 0x6020, 1), 510, "truncated to the step");
    sensor.set(1_023_900);
    bus.advance(1);
    assert_eq!(od(&mut bus, 0x6020, 1), 10239, "the end of the 6002h range");
    assert_eq!(od(&mut bus, 0x6503, 0), 0);
    assert_eq!(od(&mut bus, 0x6020, 1), 10239);
}

// Property tests of the position pipeline over the whole value ranges, on the device itself.

const MAX_UM: u32 = 10239 * 100 + 99;

fn device_at(um: u32) -> (Node<Sgh10>, Instant) {
    let mut node = Node::new(Sgh10::new(Variant::Sgh10), 1, Bitrate::K500);
    let now = Instant::from_millis(1);
    let (d, core) = node.split();
    od_core::encoder::Encoder::on_sample(d, core, Ok(um), now);
    (node, now)
}

fn sample(node: &mut Node<Sgh10>, um: u32, now: Instant) -> i64 {
    let (d, core) = node.split();
    od_core::encoder::Encoder::on_sample(d, core, Ok(um), now);
    value(node.core(), 0x6020, 1)
}

proptest! {
    #[test]
    fn scaling_is_the_reading_in_whole_steps(um in 0..=MAX_UM) {
        let (node, _) = device_at(um);
        let p = value(node.core(), 0x6020, 1);
        prop_assert!(p * 100 <= um as i64 && (um as i64) < (p + 1) * 100);
        prop_assert_eq!(value(node.core(), 0x6503, 0), 0);
    }

    #[test]
    fn calibration_round_trip(um in 0..=MAX_UM, later in 0..=MAX_UM, c in -10239i32..=10239, descending: bool) {
        let (mut node, now) = device_at(um);
        if descending {
            direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        }
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
        let moved = (later / 100) as i64 - (um / 100) as i64;
        let p = sample(&mut node, later, now);
        prop_assert_eq!(p, c as i64 + if descending { -moved } else { moved });
        // The offset is the encoder value minus the position, and the position stays
        // within the manual's transferable range.
        let m = if descending { -((later / 100) as i64) } else { (later / 100) as i64 };
        prop_assert_eq!(value(node.core(), 0x6509, 0), m - p);
        prop_assert!((-20478..=30717).contains(&p));
    }

    #[test]
    fn direction_change_mirrors_and_twice_is_identity(um in 0..=MAX_UM, c in -10239i32..=10239) {
        let (mut node, now) = device_at(um);
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), -(c as i64));
        prop_assert_eq!(value(node.core(), 0x6500, 0), 0x000C);
        direct_write(&mut node, 0x6000, 0, 0x0004, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
        prop_assert_eq!(sample(&mut node, um, now), c as i64);
    }

    #[test]
    fn work_area_state_matches_the_limits(um in 0..=MAX_UM, low in -20478i32..=30717, high in -20478i32..=30717) {
        let (mut node, now) = device_at(um);
        direct_write(&mut node, 0x6401, 1, low as u32, now).unwrap();
        direct_write(&mut node, 0x6402, 1, high as u32, now).unwrap();
        let p = (um / 100) as i32;
        let below = p < low;
        let above = p > high;
        let expected = (below || above) as i64 | (above as i64) << 1 | (below as i64) << 2;
        prop_assert_eq!(value(node.core(), 0x6400, 1), expected);
        prop_assert_eq!(value(node.core(), 0x6503, 0) & 0x1000 != 0, below || above);
        prop_assert_eq!(node.core().errors.is_active(0xFF15), below || above);
    }
}
