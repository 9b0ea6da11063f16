//! SGH50 encoder: the position pipeline over the whole value ranges (property tests on the
//! device itself) and its EMCYs on the virtual bus. The SDO scenarios of the manual's examples
//! are in `sgh50_encoder_sdo.rs`. The sensor reads the wire extension in µm; a step is 0.1 mm.

use od_core::devices::sgh50::{Sgh50, Variant};
use od_core::encoder::{Encoder, SensorFault};
use od_core::node::BusEvent;
use od_core::{Bitrate, Frame, Instant, Node};
use proptest::prelude::*;
use tests_host::bus::Bus;
use tests_host::encoder::{direct_write, value, Sensed, Sensor};

/// The largest valid reading: 73839 steps and the 99 µm below the next one.
const MAX_UM: u32 = 73839 * 100 + 99;

const SERIAL: u32 = 0x0012_D687;

fn sgh50(um: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(um);
    let mut node = Node::new(Sgh50::new(Variant::Single), 1, Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, SERIAL);
    let mut bus = Bus::new();
    bus.add(Sensed::new(node, sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    (bus, sensor)
}

#[test]
fn position_covers_the_measuring_range_and_beyond_it_is_ff05h_only() {
    let (mut bus, sensor) = sgh50(MAX_UM);
    assert_eq!(value(bus.station(0).core(), 0x6020, 1), 73839);
    sensor.set(MAX_UM + 1);
    bus.advance(1);
    // The SGH50 manual lists no speed EMCY: FF05h alone.
    bus.expect(0x081, &[0x05, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.advance(200);
    bus.expect_silence();
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 1);
    assert_eq!(value(bus.station(0).core(), 0x6020, 1), 73839);
    sensor.set(0);
    bus.advance(1);
    bus.expect(0x081, &[0x00; 8]);
    assert_eq!(value(bus.station(0).core(), 0x6020, 1), 0);
    assert_eq!(value(bus.station(0).core(), 0x1003, 1), 0xFF05);
}

#[test]
fn sensor_fault_while_error_passive_keeps_both_register_bits() {
    let (mut bus, sensor) = sgh50(10_000);
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    bus.expect(0x081, &[0x20, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    sensor.fail(SensorFault::NoResponse);
    bus.advance(1);
    bus.expect(0x081, &[0x05, 0xFF, 0x91, 0x00, 0x00, 0x00, 0x00, 0x00]);
    sensor.bus_event(BusEvent::ErrorActive);
    bus.advance(0);
    // 0000h; the register still shows the sensor error (SGH50 §3.7).
    bus.expect(0x081, &[0x00, 0x00, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect_silence();
}

#[test]
fn speed_of_the_sgh50_in_mm_per_s() {
    let (mut bus, sensor) = sgh50(3_000_000);
    sensor.move_at(-1_234_000);
    bus.advance(300);
    assert_eq!(value(bus.station(0).core(), 0x6030, 1), -1234);
}

#[test]
fn m5_recovered_from_bus_off() {
    let (mut bus, sensor) = sgh50(10_000);
    sensor.bus_event(BusEvent::BusOff);
    bus.advance(0);
    bus.expect_silence();
    sensor.bus_event(BusEvent::BusOffRecovered);
    bus.advance(0);
    bus.expect(0x081, &[0x40, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect(0x081, &[0x00; 8]);
    bus.expect_silence();
}

#[test]
fn n8_n9_node_guarding_answers_with_toggle_and_state() {
    let (mut bus, _) = sgh50(10_000);
    let rtr = Frame { rtr: true, ..Frame::std(0x701, &[0x00]) };
    bus.send(rtr);
    bus.expect(0x701, &[0x7F]);
    bus.send(rtr);
    bus.expect(0x701, &[0xFF]);
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.send(rtr);
    bus.expect(0x701, &[0x05]);
    bus.send(rtr);
    bus.expect(0x701, &[0x85]);
    bus.send(Frame::std(0x000, &[0x02, 0x01]));
    bus.send(rtr);
    bus.expect(0x701, &[0x04]);
    bus.send(rtr);
    bus.expect(0x701, &[0x84]);
}

#[test]
fn l15_to_l23_lss_inquiries_answer_the_sgh50_address() {
    let (mut bus, _) = sgh50(10_000);
    bus.send(Frame::std(0x7E5, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]));
    bus.expect_silence();
    for (cs, answer) in [
        (0x5A, [0x5A, 0x95, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]),
        (0x5B, [0x5B, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]),
        (0x5C, [0x5C, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]),
        (0x5D, [0x5D, 0x87, 0xD6, 0x12, 0x00, 0x00, 0x00, 0x00]),
        (0x5E, [0x5E, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]),
    ] {
        bus.send(Frame::std(0x7E5, &[cs, 0, 0, 0, 0, 0, 0, 0]));
        bus.expect(0x7E4, &answer);
    }
    bus.send(Frame::std(0x7E5, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]));
    bus.expect_silence();
}

fn device_at(um: u32) -> (Node<Sgh50>, Instant) {
    let mut node = Node::new(Sgh50::new(Variant::Single), 1, Bitrate::K500);
    let now = Instant::from_millis(1);
    let (d, core) = node.split();
    d.on_sample(core, Ok(um), now);
    (node, now)
}

fn sample(node: &mut Node<Sgh50>, um: u32, now: Instant) -> i64 {
    let (d, core) = node.split();
    d.on_sample(core, Ok(um), now);
    value(node.core(), 0x6020, 1)
}

proptest! {
    #[test]
    fn scaling_is_the_reading_in_whole_steps(um in 0..=MAX_UM) {
        let (node, _) = device_at(um);
        let p = value(node.core(), 0x6020, 1);
        prop_assert!(p * 100 <= um as i64 && (um as i64) < (p + 1) * 100);
    }

    #[test]
    fn readings_beyond_the_range_are_invalid(um in MAX_UM + 1..) {
        let (node, _) = device_at(um);
        prop_assert_eq!(value(node.core(), 0x6503, 0), 1);
        prop_assert!(node.core().errors.is_active(0xFF05));
    }

    #[test]
    fn calibration_round_trip(um in 0..=MAX_UM, later in 0..=MAX_UM, c in -73839i32..=73839, descending: bool) {
        let (mut node, now) = device_at(um);
        if descending {
            direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        }
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
        prop_assert_eq!(value(node.core(), 0x6509, 0), value(node.core(), 0x650C, 1));
        let moved = (later / 100) as i64 - (um / 100) as i64;
        let p = sample(&mut node, later, now);
        prop_assert_eq!(p, c as i64 + if descending { -moved } else { moved });
        prop_assert!((-147678..=221517).contains(&p));
    }

    #[test]
    fn direction_change_mirrors_and_twice_is_identity(um in 0..=MAX_UM, c in -73839i32..=73839) {
        let (mut node, now) = device_at(um);
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), -(c as i64));
        direct_write(&mut node, 0x6000, 0, 0x0004, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
    }

    #[test]
    fn out_of_range_calibration_is_refused(c in prop_oneof![i32::MIN..-73839, 73840..=i32::MAX]) {
        let (mut node, now) = device_at(1000);
        prop_assert!(direct_write(&mut node, 0x6010, 1, c as u32, now).is_err());
        prop_assert_eq!(value(node.core(), 0x6020, 1), 10);
    }
}
