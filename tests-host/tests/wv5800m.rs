//! WV5800M / WH5800M on the virtual bus: the rotary position pipeline, TPDOs, EMCYs, the LEDs
//! and LSS, byte for byte from the manual and the digest's section 6 (node-ID 1). The SDO
//! scenarios (manual examples E1-E3, digest 6.3) are in `wv5800m_sdo.rs`. Decisions in
//! docs/decisions.md, "WV5800M".

use od_core::devices::wv5800m::{Model, Turns, Variant, Wv5800m};
use od_core::encoder::{Encoder, SensorFault};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use od_core::led::{LedState, Leds};
use od_core::node::{BusEvent, Context, Output, RxIds};
use od_core::{Abort, Bitrate, Frame, Instant, NmtState, Node};
use proptest::prelude::*;
use tests_host::bus::{Bus, Station};
use tests_host::encoder::{direct_write, value, Sensed, Sensor};

const SERIAL: u32 = 0x0012_D687;
const MT12: Variant = Variant { model: Model::Wv, turns: Turns::Multi12 };
/// Raw range of the 12-bit multiturn: 16384 × 4096.
const R12: u32 = 67_108_864;

fn node(variant: Variant) -> Node<Wv5800m> {
    let mut node = Node::new(Wv5800m::new(variant), 1, Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, SERIAL);
    node
}

/// The test's side channel into the node: dictionary writes as the SDO server makes them
/// (checks, device hook, value) and the LED states, exchanged at the node's next poll.
#[derive(Default)]
struct Ctl {
    writes: VecDeque<(u16, u8, u32)>,
    results: VecDeque<Result<(), Abort>>,
    leds: Option<Leds>,
    refresh: bool,
}

/// A sampled WV5800M station with the [`Ctl`] side channel.
struct Wv {
    inner: Sensed<Wv5800m>,
    ctl: Rc<RefCell<Ctl>>,
}

impl od_core::Station for Wv {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.inner.on_frame(frame, now);
    }
    fn poll(&mut self, now: Instant) {
        let mut ctl = self.ctl.borrow_mut();
        while let Some((index, sub, v)) = ctl.writes.pop_front() {
            let r = write_entry(self.inner.node(), index, sub, v, now);
            ctl.results.push_back(r);
        }
        if self.inner.next_deadline().is_some_and(|t| t <= now) {
            self.inner.poll(now);
        }
        ctl.leds = Some(self.inner.node().device().leds());
        ctl.refresh = false;
    }
    fn next_deadline(&self) -> Option<Instant> {
        let ctl = self.ctl.borrow();
        if ctl.writes.is_empty() && !ctl.refresh {
            self.inner.next_deadline()
        } else {
            Some(Instant::ZERO)
        }
    }
    fn next_output(&mut self) -> Option<Output> {
        self.inner.next_output()
    }
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.inner.store_done(result, now);
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.inner.on_bus_event(event, now);
    }
    fn rx_ids(&self) -> RxIds {
        self.inner.rx_ids()
    }
    fn rx_ids_generation(&self) -> u32 {
        self.inner.rx_ids_generation()
    }
    fn context(&self) -> &Context {
        self.inner.context()
    }
}

impl Station for Wv {
    fn nmt(&self) -> Option<NmtState> {
        self.inner.nmt()
    }
}

/// A write as the SDO server makes it: the dictionary access path.
fn write_entry(node: &mut Node<Wv5800m>, index: u16, sub: u8, v: u32, now: Instant) -> Result<(), Abort> {
    direct_write(node, index, sub, v, now)
}

struct Rig {
    bus: Bus,
    ctl: Rc<RefCell<Ctl>>,
}

impl std::ops::Deref for Rig {
    type Target = Bus;
    fn deref(&self) -> &Bus {
        &self.bus
    }
}

impl std::ops::DerefMut for Rig {
    fn deref_mut(&mut self) -> &mut Bus {
        &mut self.bus
    }
}

fn bus(variant: Variant, raw: u32) -> (Rig, Sensor) {
    let sensor = Sensor::new(raw);
    let ctl = Rc::new(RefCell::new(Ctl::default()));
    let mut bus = Bus::new();
    bus.add(Wv { inner: Sensed::new(node(variant), sensor.clone()), ctl: ctl.clone() });
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    (Rig { bus, ctl }, sensor)
}

/// Writes through the dictionary checks and the device hook of the node, now.
#[track_caller]
fn write(rig: &mut Rig, index: u16, sub: u8, v: u32) -> Result<(), Abort> {
    rig.ctl.borrow_mut().writes.push_back((index, sub, v));
    rig.bus.advance(0);
    rig.ctl.borrow_mut().results.pop_front().expect("the write was applied")
}

/// The LED states after the node's last poll.
fn leds(rig: &mut Rig) -> Leds {
    rig.ctl.borrow_mut().refresh = true;
    rig.bus.advance(0);
    rig.ctl.borrow().leds.expect("polled")
}

#[test]
fn tpdo_position_510_speed_0_on_sync_and_rtr() {
    // Digest 6.2 "TPDO": position 510, speed 0 → FE 01 00 00 00 00.
    let (mut bus, _) = bus(MT12, 510);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 510);
    assert_eq!(value(bus.station(0).core(), 0x600C, 0), 510);
    // No PDO before OPERATIONAL.
    bus.send(Frame::std(0x080, &[]));
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x281, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame { rtr: true, ..Frame::std(0x181, &[]) });
    bus.expect(0x181, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame { rtr: true, ..Frame::std(0x281, &[]) });
    bus.expect(0x281, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.expect_silence();
}

#[test]
fn calibration_with_2002h_sets_preset_plus_offset() {
    let (mut bus, sensor) = bus(MT12, 1_000_000);
    // 6003h is a summand at all times: position = measured + 6003h + 2001h.
    write(&mut bus, 0x6003, 0, 510).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 1_000_510);
    write(&mut bus, 0x2002, 0, 1).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 510);
    assert_eq!(value(bus.station(0).core(), 0x6509, 0), 1_000_000);
    write(&mut bus, 0x2001, 0, (-10i32) as u32).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 500);
    assert_eq!(value(bus.station(0).core(), 0x650A, 1), -10);
    // The position follows the shaft from there, and wraps below 0 to the top of 6002h.
    sensor.set(1_000_100);
    bus.advance(1);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 600);
    sensor.set(999_000);
    bus.advance(1);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 67_108_864 - 500);
    // Out of range and invalid values are refused.
    assert_eq!(write(&mut bus, 0x2002, 0, 2), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6003, 0, R12), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x2001, 0, R12), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x2001, 0, (-(R12 as i32) - 1) as u32), Err(Abort::INVALID_VALUE));
}

#[test]
fn calibration_without_a_reading_is_no_data() {
    let (mut bus, sensor) = bus(MT12, 5);
    sensor.fail(SensorFault::Diagnosis);
    bus.advance(1);
    bus.expect(0x081, &[0x05, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(write(&mut bus, 0x2002, 0, 1), Err(Abort::NO_DATA));
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 1);
    sensor.heal();
    bus.advance(1);
    bus.expect(0x081, &[0x00; 8]);
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 0);
    assert_eq!(value(bus.station(0).core(), 0x1003, 1), 0xFF05);
}

#[test]
fn apu_scales_and_6002h_follows() {
    let (mut bus, _) = bus(Variant { model: Model::Wh, turns: Turns::Multi4 }, 16384 * 3 + 8192);
    assert_eq!(value(bus.station(0).core(), 0x6002, 0), 262_144);
    write(&mut bus, 0x6001, 0, 360).unwrap();
    let core = bus.station(0).core();
    assert_eq!(value(core, 0x6002, 0), 360 * 16);
    assert_eq!(value(core, 0x650A, 3), 360 * 16 - 1);
    // 3.5 revolutions at 360 steps per revolution.
    assert_eq!(value(core, 0x6004, 0), 1260);
    assert_eq!(write(&mut bus, 0x6002, 0, 262_144), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6002, 0, 5760), Ok(()));
    assert_eq!(write(&mut bus, 0x6001, 0, 0), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6001, 0, 65536), Err(Abort::INVALID_VALUE));
    // The calibration range follows the APU: 0 ..= 5759.
    assert_eq!(write(&mut bus, 0x6003, 0, 5760), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6401, 1, 5760), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6003, 0, 5759), Ok(()));
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 1259);
}

#[test]
fn direction_change_keeps_the_calibration_point() {
    let (mut bus, sensor) = bus(Variant { model: Model::Wv, turns: Turns::Single }, 4000);
    write(&mut bus, 0x6003, 0, 100).unwrap();
    write(&mut bus, 0x2002, 0, 1).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 100);
    write(&mut bus, 0x6000, 0, 0x0005).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6500, 0), 5);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 100);
    // Clockwise now counts down.
    sensor.set(4010);
    bus.advance(1);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 90);
    // Scaling cannot be switched off; unused bits are refused.
    assert_eq!(write(&mut bus, 0x6000, 0, 0x0001), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut bus, 0x6000, 0, 0x000C), Err(Abort::INVALID_VALUE));
}

#[test]
fn speed_in_increments_per_ms_with_the_direction_sign() {
    let (mut bus, sensor) = bus(MT12, 1_000_000);
    // 600 rpm = 163840 increments per second = 163.84 Inc/ms.
    sensor.move_at(163_840);
    bus.advance(300);
    assert_eq!(value(bus.station(0).core(), 0x6030, 1), 164);
    write(&mut bus, 0x6000, 0, 5).unwrap();
    assert_eq!(value(bus.station(0).core(), 0x6030, 1), -164);
    bus.advance(300);
    assert_eq!(value(bus.station(0).core(), 0x6030, 1), -164);
    bus.expect_silence();
}

#[test]
fn over_speed_lights_yellow_and_raises_ff12h() {
    let (mut bus, sensor) = bus(MT12, 1_000_000);
    assert_eq!(leds(&mut bus).yellow, LedState::Off);
    // 6100 rpm.
    sensor.move_at(6100 * 16384 / 60);
    bus.advance(250);
    bus.expect(0x081, &[0x12, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6505, 0), 1);
    assert_eq!(leds(&mut bus).yellow, LedState::On);
    // 5900 rpm: valid again.
    sensor.move_at(5900 * 16384 / 60);
    bus.advance(250);
    bus.expect(0x081, &[0x00; 8]);
    assert_eq!(value(bus.station(0).core(), 0x6505, 0), 0);
    assert_eq!(leds(&mut bus).yellow, LedState::Off);
    bus.expect_silence();
}

#[test]
fn limit_speeds_raise_ff13h_and_ff14h() {
    let (mut bus, sensor) = bus(MT12, 30_000_000);
    write(&mut bus, 0x2003, 0, (-50i16) as u16 as u32).unwrap();
    write(&mut bus, 0x2004, 0, 100).unwrap();
    sensor.move_at(150_000);
    bus.advance(250);
    bus.expect(0x081, &[0x14, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6505, 0), 1);
    sensor.move_at(-60_000);
    bus.advance(250);
    // The window across the reversal is inside the limits: FF14h removed; then FF13h.
    bus.expect(0x081, &[0x00; 8]);
    bus.expect(0x081, &[0x13, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6030, 1), -60);
    sensor.move_at(0);
    bus.advance(250);
    bus.expect(0x081, &[0x00; 8]);
    assert_eq!(value(bus.station(0).core(), 0x6505, 0), 0);
}

#[test]
fn work_areas_raise_ff15h_and_ff16h_and_0_0_is_off() {
    let (mut bus, sensor) = bus(MT12, 500);
    assert_eq!(value(bus.station(0).core(), 0x6400, 1), 0);
    write(&mut bus, 0x6401, 1, 100).unwrap();
    write(&mut bus, 0x6402, 1, 400).unwrap();
    bus.advance(0);
    bus.expect(0x081, &[0x15, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6400, 1), 0b011);
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 0x1000);
    write(&mut bus, 0x6401, 2, 600).unwrap();
    write(&mut bus, 0x6402, 2, 700).unwrap();
    bus.advance(0);
    bus.expect(0x081, &[0x16, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6400, 2), 0b101);
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 0x3000);
    sensor.set(400);
    bus.advance(1);
    bus.expect(0x081, &[0x00, 0x00, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(value(bus.station(0).core(), 0x6503, 0), 0x2000);
    bus.expect_silence();
}

#[test]
fn can_errors_emcy_and_red_led() {
    let (mut bus, sensor) = bus(MT12, 5);
    assert_eq!(leds(&mut bus).green, LedState::Flashing);
    assert_eq!(leds(&mut bus).red, LedState::Off);
    sensor.bus_event(BusEvent::ErrorCounters { rx: 0, tx: 96 });
    bus.advance(0);
    assert_eq!(leds(&mut bus).red, LedState::SingleFlash);
    assert_eq!(value(bus.station(0).core(), 0x1002, 0), 0x6000);
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    // Digest 6.2 EMCY "error passive": 20 81 ER.
    bus.expect(0x081, &[0x20, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    sensor.bus_event(BusEvent::BusOff);
    bus.advance(0);
    bus.expect_silence();
    assert_eq!(leds(&mut bus).red, LedState::On);
    sensor.bus_event(BusEvent::BusOffRecovered);
    bus.advance(0);
    // Error passive ends with the recovery; then "recovered from bus-off": 40 81 ER, and its
    // removal.
    bus.expect(0x081, &[0x00; 8]);
    bus.expect(0x081, &[0x40, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect(0x081, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(leds(&mut bus).red, LedState::Off);
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.advance(0);
    assert_eq!(leds(&mut bus).green, LedState::On);
    bus.send(Frame::std(0x000, &[0x02, 0x01]));
    bus.advance(0);
    assert_eq!(leds(&mut bus).green, LedState::SingleFlash);
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::Stopped);
}

#[test]
fn guard_event_double_flashes_the_red_led_until_the_next_rtr() {
    let (mut bus, _) = bus(MT12, 5);
    write(&mut bus, 0x100C, 0, 100).unwrap();
    write(&mut bus, 0x100D, 0, 3).unwrap();
    // Guarding starts with the master's first RTR: 7Fh, toggle 0.
    bus.send(Frame { rtr: true, ..Frame::std(0x701, &[]) });
    bus.expect(0x701, &[0x7F]);
    bus.advance(299);
    assert_eq!(leds(&mut bus).red, LedState::Off);
    bus.advance(2);
    assert_eq!(leds(&mut bus).red, LedState::DoubleFlash);
    bus.send(Frame { rtr: true, ..Frame::std(0x701, &[]) });
    bus.expect(0x701, &[0xFF]);
    assert_eq!(leds(&mut bus).red, LedState::Off);
}

#[test]
fn digest_6_2_heartbeat_and_nmt() {
    let (mut bus, _) = bus(MT12, 510);
    assert_eq!(write(&mut bus, 0x1017, 0, 9), Err(Abort::INVALID_VALUE));
    write(&mut bus, 0x1017, 0, 100).unwrap();
    let t0 = bus.now();
    bus.advance(100);
    let seen = bus.expect(0x701, &[0x7F]);
    assert_eq!(seen.at, t0.add_millis(100));
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.advance(100);
    bus.expect(0x701, &[0x05]);
    bus.send(Frame::std(0x000, &[0x02, 0x00]));
    bus.advance(100);
    bus.expect(0x701, &[0x04]);
    // STOPPED: no PDO on SYNC.
    bus.send(Frame::std(0x080, &[]));
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x80, 0x01]));
    bus.advance(100);
    bus.expect(0x701, &[0x7F]);
    // Reset communication: boot-up.
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x701, &[0x00]);
}

#[test]
fn lss_configuration_flickers_both_leds() {
    let (mut bus, _) = bus(MT12, 5);
    bus.send(Frame::std(0x7E5, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]));
    bus.expect_silence();
    let l = leds(&mut bus);
    assert_eq!((l.green, l.red), (LedState::Flickering, LedState::Flickering));
    let lit = l.lit(Instant::from_millis(10));
    assert!(lit.green && !lit.red);
    let lit = l.lit(Instant::from_millis(60));
    assert!(!lit.green && lit.red);
    bus.send(Frame::std(0x7E5, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]));
    bus.expect_silence();
    // LSS waiting is not shown: back to PRE-OPERATIONAL flashing.
    assert_eq!(leds(&mut bus).green, LedState::Flashing);
}

#[test]
fn lss_digest_6_2_l1_to_l19() {
    let (mut bus, _) = bus(MT12, 5);
    let lss = |bus: &mut Bus, d: [u8; 8]| bus.send(Frame::std(0x7E5, &d));
    // L3-L7: switch selective by the LSS address.
    lss(&mut bus, [0x40, 0x95, 0x01, 0x00, 0x00, 0, 0, 0]);
    lss(&mut bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss(&mut bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    bus.expect_silence();
    let s = SERIAL.to_le_bytes();
    lss(&mut bus, [0x43, s[0], s[1], s[2], s[3], 0, 0, 0]);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    // L15-L19: inquire.
    lss(&mut bus, [0x5A, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5A, 0x95, 0x01, 0x00, 0x00, 0, 0, 0]);
    lss(&mut bus, [0x5B, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5B, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss(&mut bus, [0x5C, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5C, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss(&mut bus, [0x5D, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5D, s[0], s[1], s[2], s[3], 0, 0, 0]);
    lss(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5E, 0x01, 0, 0, 0, 0, 0, 0]);
    // L10/L11: 250 kbit/s (index 3) → 5F0Ah.02 = 4; index 5 is reserved.
    lss(&mut bus, [0x13, 0x00, 0x03, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x13, 0x00, 0, 0, 0, 0, 0, 0]);
    assert_eq!(value(bus.station(0).core(), 0x5F0A, 2), 4);
    lss(&mut bus, [0x13, 0x00, 0x05, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x13, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x13, 0x00, 0x02, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x13, 0x00, 0, 0, 0, 0, 0, 0]);
    // L8/L9: node-ID 5; 0 and 80h are invalid.
    lss(&mut bus, [0x11, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x11, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x11, 0x80, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x11, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x11, 0x00, 0, 0, 0, 0, 0, 0]);
    assert_eq!(value(bus.station(0).core(), 0x5F0A, 1), 5);
    // L13/L14: store configuration.
    lss(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x17, 0x00, 0, 0, 0, 0, 0, 0]);
    // L2, then NMT reset communication: boot-up on 705h.
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x705, &[0x00]);
    // L1: switch state global to configuration; inquire node-ID answers 5.
    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x5E, 0x05, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
}

#[test]
fn raw_beyond_the_range_is_a_sensor_fault() {
    let (mut bus, sensor) = bus(Variant { model: Model::Wv, turns: Turns::Single }, 16383);
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 16383);
    sensor.set(16384);
    bus.advance(1);
    bus.expect(0x081, &[0x05, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // The last valid position stays.
    assert_eq!(value(bus.station(0).core(), 0x6004, 0), 16383);
}

#[test]
fn multiturn_wrap_around_keeps_speed_and_position_continuous() {
    // The sensor wraps after 4096 revolutions; the shell feeds the raw count as it comes.
    let mut n = node(MT12);
    let mut t = Instant::ZERO;
    let mut raw = R12 - 5_000;
    let mut positions = Vec::new();
    for _ in 0..40 {
        let (device, core) = n.split();
        device.on_sample(core, Ok(raw), t);
        positions.push(value(n.core(), 0x6004, 0) as u32);
        raw = (raw + 250) % R12;
        t = t.add_millis(10);
    }
    // 250 increments per 10 ms = 25 Inc/ms, straight across the wrap.
    assert_eq!(value(n.core(), 0x6030, 1), 25);
    for w in positions.windows(2) {
        assert_eq!((w[1] + R12 - w[0]) % R12, 250);
    }
    assert!(positions.iter().any(|&p| p < 5_000) && positions.iter().any(|&p| p > R12 - 5_000));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn preset_round_trip_on_the_device(
        k in 0usize..4, apu in 1u32..=65535, raw in any::<u32>(), preset in any::<u32>(), ccw in any::<bool>()
    ) {
        let turns = [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12][k];
        let n = turns.revolutions();
        let r = 16384 * n;
        let t = apu * n;
        let mut node = node(Variant { model: Model::Wv, turns });
        let now = Instant::ZERO;
        let raw = raw % r;
        {
            let (device, core) = node.split();
            device.on_sample(core, Ok(raw), now);
        }
        direct_write(&mut node, 0x6000, 0, if ccw { 5 } else { 4 }, now).unwrap();
        direct_write(&mut node, 0x6001, 0, apu, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6002, 0) as u32, t);
        let p = preset % t;
        direct_write(&mut node, 0x6003, 0, p, now).unwrap();
        direct_write(&mut node, 0x2002, 0, 1, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6004, 0) as u32, p);
        // One revolution on in the counting direction is APU steps on.
        let next = if ccw { (raw + r - 16384) % r } else { (raw + 16384) % r };
        {
            let (device, core) = node.split();
            device.on_sample(core, Ok(next), now.add_millis(1));
        }
        prop_assert_eq!(value(node.core(), 0x6004, 0) as u32, (p + apu) % t);
    }
}
