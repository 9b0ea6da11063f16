//! The WV58MR as a J1939 node on the virtual bus, in virtual time: every example frame of the
//! manual (§5.5.3, E1-E3) and of the digest's section 6.2 (D1-D26), byte for byte, address
//! claiming (the 250 ms, a contest won and lost, Cannot Claim, a Request for Address Claimed),
//! the cyclic groups before and after a cycle-time change, a NACK, every abort class, the LEDs,
//! EMCY, and store -> power cycle -> kept.

use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::{table_of, Wv58mr};
use od_core::encoder::SensorFault;
use od_core::j1939::node::J1939Node;
use od_core::led::LedState;
use od_core::storage::{identity, ParamFlash};
use od_core::wire::j1939::{Address, AddressClaimed, Name, Pgn, Request};
use od_core::{Bitrate, BusEvent, CanId, Frame, Instant};
use tests_host::bus::{Bus, Seen};
use tests_host::encoder::Sensor;
use tests_host::flash::RamFlash;
use tests_host::j1939::{cam_exchange, cam_read, of_group, raw_id, SensedJ1939};
use tests_host::sim::devices::{factory_pages, REGION};

const MASTER: Address = Address(0x00);
const EF: Address = Address(0xEF);
const SERIAL: u32 = 0x0001_2345;
/// The NAME of serial 12345h (digest D26): identity 12345h, manufacturer 0471h, function 8Eh,
/// industry group 3, arbitrary address capable.
const NAME: [u8; 8] = [0x45, 0x23, 0x21, 0x8E, 0x00, 0x8E, 0x00, 0xB0];

fn ext(id: u32, data: &[u8]) -> Frame {
    Frame::new(CanId::Ext(id), data)
}

/// A WV58MR (12-bit multiturn) with `serial` on a 250 kbit/s bus, its flash programmed with
/// `address` (None: the default EFh), the sensor at `raw`.
fn device(bus: &mut Bus, serial: u32, address: Option<u8>, raw: u32) -> (usize, Sensor) {
    let table = table_of(Turns::Multi12);
    let pages = factory_pages(table, address, Some(serial)).unwrap();
    let params = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
    let sensor = Sensor::new(raw);
    let s = sensor.clone();
    let n = bus.add_with_flash(params, move |loaded| {
        SensedJ1939::new(J1939Node::boot(Wv58mr::new(Turns::Multi12), loaded), s.clone())
    });
    (n, sensor)
}

fn setup(raw: u32) -> (Bus, usize, Sensor) {
    let mut bus = Bus::new();
    bus.set_bitrate(Bitrate::K250);
    let (n, sensor) = device(&mut bus, SERIAL, None, raw);
    (bus, n, sensor)
}

/// The pseudo-random start delay of the NAME of `serial` (D-J1939-13).
fn delay_us(serial: u32) -> u64 {
    let name = Name::from_raw(0xB000_8E00_8E20_0000 | (serial & 0x1F_FFFF) as u64);
    od_core::j1939::claim::AddressClaimer::new(name, EF, 0x80, 0xEF).random_delay_us()
}

/// Runs until the claim of the device at `address` stood; returns the frames seen.
fn claimed(bus: &mut Bus, serial: u32) -> Vec<Seen> {
    bus.advance_to(Instant::from_micros(delay_us(serial)).add_millis(250));
    bus.drain()
}

fn only(frames: &[Seen]) -> Vec<(u32, Vec<u8>)> {
    frames.iter().map(|s| (raw_id(&s.frame), s.frame.payload().to_vec())).collect()
}

#[test]
fn d26_claims_ef_after_its_delay_and_publishes_only_after_250_ms() {
    let (mut bus, _, _) = setup(SERIAL);
    let d = delay_us(SERIAL);
    bus.advance_to(Instant::from_micros(d).add_millis(249));
    let seen = bus.drain();
    assert_eq!(only(&seen), vec![(0x18EE_FFEF, NAME.to_vec())]);
    assert_eq!(seen[0].at, Instant::from_micros(d));
    bus.advance(1);
    // D1 and the speed at rest: EPOS and ESPD at once, priority 3.
    let seen = bus.drain();
    assert_eq!(
        only(&seen),
        vec![
            (0x0CFC_61EF, vec![0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]),
            (0x0CFC_5FEF, vec![0x45, 0x23, 0x01, 0x00, 0xFF, 0xFF, 0xFF, 0xFF]),
        ]
    );
    // Every 50 ms (3000h.02/.03 = 32h); no Proprietary B (3000h.01 = 0).
    bus.advance(500);
    let seen = bus.drain();
    let epos = of_group(&seen, Pgn::EPOS);
    assert_eq!(epos.len(), 10);
    for w in epos.windows(2) {
        assert_eq!(w[1].at.micros_since(w[0].at), 50_000);
    }
    assert_eq!(of_group(&seen, Pgn::ESPD).len(), 10);
    assert!(of_group(&seen, Pgn::PROPRIETARY_B).is_empty());
}

#[test]
fn green_blinks_while_claiming_and_is_on_once_the_claim_stood() {
    let (mut bus, n, _) = setup(0);
    let leds = |bus: &mut Bus| bus.station(n).panel().unwrap();
    bus.advance(1);
    assert_eq!(leds(&mut bus), "green=Flashing red=Off yellow=Off");
    claimed(&mut bus, SERIAL);
    assert_eq!(leds(&mut bus), "green=On red=Off yellow=Off");
    let _ = LedState::On;
}

#[test]
fn the_device_shows_the_same_leds_as_its_node_in_virtual_time() {
    let table = table_of(Turns::Multi12);
    let pages = factory_pages(table, None, Some(SERIAL)).unwrap();
    let mut params = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
    let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &params.load());
    assert_eq!(node.device().leds().green, LedState::Off, "before the start");
    let d = delay_us(SERIAL);
    let mut t = Instant::ZERO;
    // Blinking green while claiming: 200 ms on, 200 ms off, on the device as on the node.
    while t < Instant::from_micros(d).add_millis(250) {
        node.poll(t);
        while node.next_output().is_some() {}
        assert_eq!(node.device().leds(), node.leds(), "{t:?}");
        if t > Instant::ZERO {
            assert_eq!(node.leds().green, LedState::Flashing);
            let lit = node.device().leds().lit(t).green;
            assert_eq!(lit, t.as_micros() % 400_000 < 200_000, "{t:?}");
        }
        t = match node.next_deadline() {
            Some(n) if n > t => n.min(t.add_millis(50)),
            _ => t.add_millis(50),
        };
    }
    node.poll(Instant::from_micros(d).add_millis(250));
    assert_eq!(node.device().leds().green, LedState::On);
}

#[test]
fn d2_d3_speed_in_espd() {
    let (mut bus, _, sensor) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    sensor.move_at(100_000); // 100 Inc/ms
    bus.advance(300);
    let espd = of_group(&bus.drain(), Pgn::ESPD);
    assert_eq!(espd.last().unwrap().frame.payload(), [0x64, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    sensor.move_at(-2_000); // -2 Inc/ms
    bus.advance(300);
    let espd = of_group(&bus.drain(), Pgn::ESPD);
    assert_eq!(raw_id(&espd.last().unwrap().frame), 0x0CFC_61EF);
    assert_eq!(espd.last().unwrap().frame.payload(), [0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
}

#[test]
fn e1_read_the_calibration_value() {
    let (mut bus, _, _) = setup(1000);
    claimed(&mut bus, SERIAL);
    // The value the manual's frame carries, 510 (A5), written first.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.send(ext(0x1C06_EF00, &[0x40, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]));
    let answer = bus.drain().into_iter().find(|s| raw_id(&s.frame) == 0x1C05_00EF).expect("CAM11 answer");
    assert_eq!(answer.frame.payload(), [0x43, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00]);
}

#[test]
fn e2_e3_cycle_time_stored_and_kept_over_a_power_cycle() {
    // The manual's WH58MR sits at 4Ah, outside the 80h..EFh 5F0Ah.01 accepts (A26,
    // D-J1939-22): the example runs at EFh, its frames otherwise byte for byte.
    let (mut bus, n, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    bus.send(ext(0x1C06_EF00, &[0x2B, 0x00, 0x30, 0x03, 0x64, 0x00, 0x00, 0x00]));
    let seen = bus.drain();
    let cam = seen.iter().find(|s| raw_id(&s.frame) == 0x1C05_00EF).expect("E2 answer");
    assert_eq!(cam.frame.payload(), [0x60, 0x00, 0x30, 0x03, 0x00, 0x00, 0x00, 0x00]);
    // EPOS now every 100 ms; 6200h reads 0064h.
    bus.advance(1000);
    let epos = of_group(&bus.drain(), Pgn::EPOS);
    assert!(epos.len() == 10 || epos.len() == 11, "{}", epos.len());
    for w in epos.windows(2) {
        assert_eq!(w[1].at.micros_since(w[0].at), 100_000);
    }
    assert_eq!(raw_id(&epos[0].frame), 0x0CFC_5FEF);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x6200, 0), [0x4B, 0x00, 0x62, 0x00, 0x64, 0x00, 0x00, 0x00]);
    // E3: store all.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]);
    assert_eq!(a, [0x60, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00]);
    // Power cycle: the claim again, then EPOS every 100 ms.
    bus.power_cycle(n);
    let t0 = bus.now();
    bus.advance_to(t0.add_micros(delay_us(SERIAL)).add_millis(250 + 1000));
    let seen = bus.drain();
    assert_eq!(raw_id(&seen[0].frame), 0x18EE_FFEF);
    let epos = of_group(&seen, Pgn::EPOS);
    assert_eq!(epos.len(), 11);
    for w in epos.windows(2) {
        assert_eq!(w[1].at.micros_since(w[0].at), 100_000);
    }
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x3000, 3), [0x4B, 0x00, 0x30, 0x03, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x6200, 0), [0x4B, 0x00, 0x62, 0x00, 0x64, 0x00, 0x00, 0x00]);
}

#[test]
fn an_unsaved_change_is_lost_over_a_power_cycle() {
    let (mut bus, n, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x03, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    bus.power_cycle(n);
    let t = bus.now();
    bus.advance_to(t.add_micros(delay_us(SERIAL)).add_millis(250));
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x6200, 0)[4], 0x32);
}

#[test]
fn d4_to_d6_proprietary_b_switched_on_with_position_and_speed() {
    let (mut bus, _, sensor) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    sensor.move_at(100_000);
    bus.advance(150);
    sensor.move_at(0);
    sensor.set(SERIAL);
    bus.advance(95);
    bus.drain();
    // 6030h.01 still holds the last window's 100 Inc/ms (the window closes every 100 ms).
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x01, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x00, 0x30, 0x01, 0x00, 0x00, 0x00, 0x00]);
    let t = bus.now();
    bus.advance(300);
    let b = of_group(&bus.drain(), Pgn::PROPRIETARY_B);
    assert_eq!(raw_id(&b[0].frame), 0x18FF_AAEF);
    assert_eq!(b[0].at, t, "switched on from 0: sent at once");
    assert_eq!(b[0].frame.payload()[..4], [0x45, 0x23, 0x01, 0x00]);
    assert_eq!(b[0].frame.payload()[6..], [0x00, 0x00]);
    assert_eq!(b.len(), 4);
    for w in b.windows(2) {
        assert_eq!(w[1].at.micros_since(w[0].at), 100_000);
    }
    // D6 with a speed of 100 Inc/ms.
    sensor.move_at(100_000);
    bus.advance(200);
    let b = of_group(&bus.drain(), Pgn::PROPRIETARY_B);
    assert_eq!(b.last().unwrap().frame.payload()[4..], [0x64, 0x00, 0x00, 0x00]);
    // 0 switches it off again.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x01, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    bus.advance(500);
    assert!(of_group(&bus.drain(), Pgn::PROPRIETARY_B).is_empty());
}

#[test]
fn d6_proprietary_b_bytes() {
    let (mut bus, _, sensor) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    // A speed of exactly 100 Inc/ms over the last window, the position back at 12345h.
    sensor.move_at(100_000);
    bus.advance(200);
    sensor.move_at(0);
    sensor.set(SERIAL);
    bus.advance(1);
    bus.drain();
    // The position is sampled every ms; the speed is the last closed window's.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x01, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let b = of_group(&bus.drain(), Pgn::PROPRIETARY_B);
    let b = match b.first() {
        Some(b) => *b,
        None => {
            bus.advance(0);
            of_group(&bus.drain(), Pgn::PROPRIETARY_B)[0]
        }
    };
    assert_eq!(b.frame.payload(), [0x45, 0x23, 0x01, 0x00, 0x64, 0x00, 0x00, 0x00]);
}

#[test]
fn d7_to_d14_reads() {
    let (mut bus, _, _) = setup(0);
    claimed(&mut bus, SERIAL);
    let read = |bus: &mut Bus, req: [u8; 8]| cam_exchange(bus, EF, MASTER, req).1;
    assert_eq!(read(&mut bus, [0x40, 0x00, 0x30, 0x02, 0, 0, 0, 0]), [0x4B, 0x00, 0x30, 0x02, 0x32, 0x00, 0x00, 0x00]);
    assert_eq!(read(&mut bus, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]), [0x4F, 0x0A, 0x5F, 0x01, 0xEF, 0x00, 0x00, 0x00]);
    assert_eq!(read(&mut bus, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x02, 0x00]);
    assert_eq!(read(&mut bus, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]), [0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0x00, 0x00]);
    // The NAME's identity number is the serial number (D-J1939-16).
    assert_eq!(read(&mut bus, [0x40, 0x01, 0x30, 0x01, 0, 0, 0, 0]), [0x43, 0x01, 0x30, 0x01, 0x45, 0x23, 0x01, 0x00]);
    assert_eq!(read(&mut bus, [0x40, 0x01, 0x30, 0x02, 0, 0, 0, 0]), [0x4B, 0x01, 0x30, 0x02, 0x71, 0x04, 0x00, 0x00]);
}

#[test]
fn d12_singleturn_device_type() {
    let mut bus = Bus::new();
    bus.set_bitrate(Bitrate::K250);
    let table = table_of(Turns::Single);
    let pages = factory_pages(table, None, Some(SERIAL)).unwrap();
    let params = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
    let s = Sensor::new(0);
    bus.add_with_flash(params, move |l| SensedJ1939::new(J1939Node::boot(Wv58mr::new(Turns::Single), l), s.clone()));
    claimed(&mut bus, SERIAL);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x1000, 0), [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00]);
}

#[test]
fn d15_d16_preset_calibrates() {
    let (mut bus, _, sensor) = setup(70_000);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x01, 0x20, 0x00, 0x0A, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60, "2001h := 10");
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x03, 0x60, 0x00, 0x12, 0x02, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // 6004h = 530 + 2001h at the calibration point, and follows the shaft from there.
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x6004, 0), [0x43, 0x04, 0x60, 0x00, 0x1C, 0x02, 0x00, 0x00]);
    sensor.set(70_100);
    bus.advance(2);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x6004, 0)[4..6], (540u16 + 100).to_le_bytes());
    bus.advance(100);
    let epos = of_group(&bus.drain(), Pgn::EPOS);
    assert_eq!(epos.last().unwrap().frame.payload()[..4], 640u32.to_le_bytes());
}

#[test]
fn d17_d18_d21_restore_then_restart_loads_the_defaults() {
    let (mut bus, _, _) = setup(0);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x02, 0x0A, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]);
    assert_eq!(a[0], 0x60);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64]);
    assert_eq!(a, [0x60, 0x11, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00]);
    // Until the reset the values stay.
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x3000, 2)[4], 0x0A);
    // D21: restart. The answer comes first, then the claim after the delay.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x02, 0x30, 0x02, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x02, 0x30, 0x02, 0x00, 0x00, 0x00, 0x00]);
    let t = bus.now();
    bus.advance_to(t.add_micros(delay_us(SERIAL)).add_millis(250));
    let seen = bus.drain();
    assert_eq!(only(&seen)[0], (0x18EE_FFEF, NAME.to_vec()));
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x3000, 2)[4], 0x32);
}

#[test]
fn d19_d20_d21_new_address_after_store_and_restart() {
    let (mut bus, n, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x0A, 0x5F, 0x01, 0x80, 0x00, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x0A, 0x5F, 0x01, 0x00, 0x00, 0x00, 0x00]);
    // Still EFh until the restart.
    bus.advance(60);
    assert!(of_group(&bus.drain(), Pgn::EPOS).iter().all(|s| raw_id(&s.frame) == 0x0CFC_5FEF));
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65]);
    assert_eq!(a, [0x60, 0x10, 0x10, 0x04, 0x00, 0x00, 0x00, 0x00]);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x02, 0x30, 0x02, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let t = bus.now();
    bus.advance_to(t.add_micros(delay_us(SERIAL)).add_millis(249));
    let seen = bus.drain();
    assert_eq!(only(&seen), vec![(0x18EE_FF80, NAME.to_vec())]);
    bus.advance(1);
    assert_eq!(raw_id(&of_group(&bus.drain(), Pgn::EPOS)[0].frame), 0x0CFC_5F80);
    // And after a power cycle.
    bus.power_cycle(n);
    let t = bus.now();
    bus.advance_to(t.add_micros(delay_us(SERIAL)).add_millis(250));
    assert_eq!(raw_id(&bus.drain()[0].frame), 0x18EE_FF80);
}

#[test]
fn d22_epos_priority() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x00, 0x30, 0x06, 0x02, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    bus.advance(60);
    let epos = of_group(&bus.drain(), Pgn::EPOS);
    assert_eq!(raw_id(&epos.last().unwrap().frame), 0x08FC_5FEF);
}

#[test]
fn d23_to_d25_emcy() {
    let (mut bus, n, sensor) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    sensor.fail(SensorFault::Diagnosis);
    bus.advance(2);
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x05, 0xFF, 0x81, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
    sensor.heal();
    bus.advance(2);
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
    // D24: error passive, once; the red LED from the warning limit.
    sensor.bus_event(BusEvent::ErrorCounters { rx: 0, tx: 100 });
    bus.advance(0);
    assert_eq!(bus.station(n).panel().unwrap(), "green=On red=On yellow=Off");
    assert!(bus.drain().iter().all(|s| raw_id(&s.frame) != 0x04FC_68EF), "no EMCY at the warning limit");
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    sensor.bus_event(BusEvent::ErrorPassive);
    bus.advance(0);
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x20, 0x81, 0x11, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
    // D25.
    sensor.bus_event(BusEvent::ErrorActive);
    sensor.bus_event(BusEvent::ErrorCounters { rx: 0, tx: 0 });
    bus.advance(0);
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
    assert_eq!(bus.station(n).panel().unwrap(), "green=On red=Off yellow=Off");
}

#[test]
fn a_fault_present_at_power_on_is_announced_when_the_claim_stood() {
    let (mut bus, _, sensor) = setup(SERIAL);
    sensor.fail(SensorFault::NoResponse);
    bus.advance_to(Instant::from_micros(delay_us(SERIAL)).add_millis(249));
    let seen = bus.drain();
    assert!(seen.iter().all(|s| raw_id(&s.frame) != 0x04FC_68EF), "nothing but the claim for 250 ms");
    bus.advance(1);
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x05, 0xFF, 0x81, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
}

#[test]
fn request_for_address_claimed_and_for_groups_and_a_nack() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    bus.advance(10);
    bus.drain();
    // Global request for Address Claimed.
    bus.send(ext(0x18EA_FF00, &[0x00, 0xEE, 0x00]));
    assert_eq!(only(&bus.drain()), vec![(0x18EE_FFEF, NAME.to_vec())]);
    // Request for EPOS to us: EPOS now.
    bus.send(ext(0x18EA_EF00, &[0x5F, 0xFC, 0x00]));
    assert_eq!(only(&bus.drain()), vec![(0x0CFC_5FEF, vec![0x45, 0x23, 0x01, 0x00, 0xFF, 0xFF, 0xFF, 0xFF])]);
    // Request for EMCY to us: NACK (J1939-21), to the global address.
    bus.send(ext(0x18EA_EF21, &[0x68, 0xFC, 0x00]));
    assert_eq!(only(&bus.drain()), vec![(0x18E8_FFEF, vec![0x01, 0xFF, 0xFF, 0xFF, 0x21, 0x68, 0xFC, 0x00])]);
    // The same globally: silence.
    bus.send(ext(0x18EA_FF21, &[0x68, 0xFC, 0x00]));
    bus.expect_silence();
    // A CAM21 to the global address is not answered (D-J1939-12).
    bus.send(ext(0x1C06_FF00, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    bus.expect_silence();
}

#[test]
fn every_abort_class() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    let abort = |bus: &mut Bus, req: [u8; 8], code: u32| {
        let (_, a) = cam_exchange(bus, EF, MASTER, req);
        let mut want = [0x80, req[1], req[2], req[3], 0, 0, 0, 0];
        want[4..].copy_from_slice(&code.to_le_bytes());
        assert_eq!(a, want, "{req:02X?}");
    };
    abort(&mut bus, [0x40, 0x00, 0x70, 0x00, 0, 0, 0, 0], 0x0602_0000); // no object
    abort(&mut bus, [0x40, 0x00, 0x30, 0x07, 0, 0, 0, 0], 0x0609_0011); // no sub-index
    abort(&mut bus, [0x23, 0x04, 0x60, 0x00, 1, 0, 0, 0], 0x0601_0002); // read-only
    abort(&mut bus, [0x40, 0x02, 0x30, 0x02, 0, 0, 0, 0], 0x0601_0001); // write-only
    abort(&mut bus, [0x2B, 0x01, 0x60, 0x00, 1, 0, 0, 0], 0x0607_0013); // too short
    abort(&mut bus, [0x2F, 0x0A, 0x5F, 0x01, 0x7F, 0, 0, 0], 0x0609_0030); // address out of range
    abort(&mut bus, [0x2F, 0x00, 0x30, 0x06, 0x08, 0, 0, 0], 0x0609_0030); // priority 8
    abort(&mut bus, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x66], 0x0800_0020); // not "save"
    abort(&mut bus, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x65], 0x0800_0020);
    // not "load"
}

#[test]
fn cycle_time_change_counts_from_the_last_transmission() {
    let (mut bus, _, _) = setup(SERIAL);
    let mut seen = claimed(&mut bus, SERIAL);
    bus.advance(20);
    seen.extend(bus.drain());
    let before = of_group(&seen, Pgn::EPOS);
    let last = before.last().unwrap().at;
    // 6200h := 200 ms (the same value as 3000h.03).
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x62, 0x00, 0xC8, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x3000, 3)[4..6], [0xC8, 0x00]);
    bus.advance(1000);
    let epos = of_group(&bus.drain(), Pgn::EPOS);
    assert_eq!(epos[0].at, last.add_millis(200));
    for w in epos.windows(2) {
        assert_eq!(w[1].at.micros_since(w[0].at), 200_000);
    }
    // 0 switches EPOS off.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2B, 0x00, 0x30, 0x03, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    bus.advance(1000);
    assert!(of_group(&bus.drain(), Pgn::EPOS).is_empty());
}

#[test]
fn contest_won_and_lost_against_another_ca() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    bus.advance(1);
    bus.drain();
    // A CA with a higher NAME claims EFh: we defend with our claim.
    let higher = AddressClaimed { name: Name::from_raw(0xB000_8E00_8E3F_FFFF) };
    bus.send(higher.frame(EF));
    assert_eq!(only(&bus.drain()), vec![(0x18EE_FFEF, NAME.to_vec())]);
    // A lower NAME wins: we move to 80h, silent for 250 ms, then publish from there.
    let lower = AddressClaimed { name: Name::from_raw(0x3000_8E00_8E20_0000) };
    bus.send(lower.frame(EF));
    let t = bus.now();
    assert_eq!(only(&bus.drain()), vec![(0x18EE_FF80, NAME.to_vec())]);
    bus.advance(249);
    assert!(bus.drain().is_empty());
    bus.advance(1);
    let seen = bus.drain();
    assert_eq!(seen[0].at, t.add_millis(250));
    assert_eq!(raw_id(&of_group(&seen, Pgn::EPOS)[0].frame), 0x0CFC_5F80);
}

#[test]
fn cannot_claim_when_every_address_is_taken() {
    let (mut bus, n, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    // Other CAs hold 80h..EEh.
    for a in 0x80..0xEF {
        bus.send(AddressClaimed { name: Name::from_raw(0x1000 + a as u64) }.frame(Address(a)));
    }
    bus.drain();
    bus.send(AddressClaimed { name: Name::from_raw(1) }.frame(EF));
    assert_eq!(only(&bus.drain()), vec![(0x18EE_FFFE, NAME.to_vec())]);
    bus.advance(1000);
    assert!(bus.drain().is_empty(), "silent");
    assert_eq!(bus.station(n).panel().unwrap(), "green=Flashing red=Off yellow=Off");
    // A global Request for Address Claimed gets Cannot Claim after the pseudo-random delay.
    bus.send(Request { pgn: Pgn::ADDRESS_CLAIMED }.frame(Address::GLOBAL, MASTER));
    let t = bus.now();
    bus.advance(200);
    let seen = bus.drain();
    assert_eq!(only(&seen), vec![(0x18EE_FFFE, NAME.to_vec())]);
    assert_eq!(seen[0].at, t.add_micros(delay_us(SERIAL)));
}

#[test]
fn redundant_pair_both_claim_and_publish() {
    let mut bus = Bus::new();
    bus.set_bitrate(Bitrate::K250);
    let (_, _) = device(&mut bus, 1000, None, 100);
    let (_, _) = device(&mut bus, 1001, None, 200);
    bus.advance(1000);
    let seen = bus.drain();
    let claims: Vec<_> =
        seen.iter().filter(|s| raw_id(&s.frame) >> 8 == 0x18EEFF).map(|s| raw_id(&s.frame) & 0xFF).collect();
    // The lower NAME (serial 1000) keeps EFh, the other moves to 80h.
    assert!(claims.contains(&0xEF) && claims.contains(&0x80), "{claims:02X?}");
    let epos = of_group(&seen, Pgn::EPOS);
    let from = |sa: u32| epos.iter().filter(|s| raw_id(&s.frame) & 0xFF == sa).count();
    assert!(from(0xEF) >= 10 && from(0x80) >= 10, "{} {}", from(0xEF), from(0x80));
    let ef = epos.iter().find(|s| raw_id(&s.frame) & 0xFF == 0xEF).unwrap();
    assert_eq!(ef.frame.payload()[..4], 100u32.to_le_bytes());
}

#[test]
fn store_fails_answers_an_abort() {
    let (mut bus, n, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    bus.fail_stores(n, true);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]);
    assert_eq!(a, [0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08]);
}

#[test]
fn over_speed_blinks_yellow_and_raises_ff12h() {
    let (mut bus, n, sensor) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    // 2000 Inc/ms, above 6000 rpm (1638.4 Inc/ms).
    sensor.move_at(2_000_000);
    bus.advance(250);
    assert_eq!(bus.station(n).panel().unwrap(), "green=On red=Off yellow=Flashing");
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x12, 0xFF, 0x81, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
    sensor.move_at(0);
    bus.advance(250);
    assert_eq!(bus.station(n).panel().unwrap(), "green=On red=Off yellow=Off");
    let emcy: Vec<_> = bus.drain().into_iter().filter(|s| raw_id(&s.frame) == 0x04FC_68EF).collect();
    assert_eq!(only(&emcy), vec![(0x04FC_68EF, vec![0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])]);
}

#[test]
fn sae_initialise_claims_again_at_the_address_in_ram() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x0A, 0x5F, 0x01, 0x90, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x2F, 0x02, 0x30, 0x01, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x02, 0x30, 0x01, 0x00, 0x00, 0x00, 0x00], "answered from EFh");
    let t = bus.now();
    bus.advance_to(t.add_micros(delay_us(SERIAL)).add_millis(249));
    assert_eq!(only(&bus.drain()), vec![(0x18EE_FF90, NAME.to_vec())]);
    bus.advance(1);
    assert_eq!(raw_id(&of_group(&bus.drain(), Pgn::EPOS)[0].frame), 0x0CFC_5F90);
    // The dictionary stayed: 5F0Ah.01 reads 90h, unsaved.
    assert_eq!(cam_read(&mut bus, Address(0x90), MASTER, 0x5F0A, 1)[4], 0x90);
}

#[test]
fn nothing_is_answered_before_the_claim_stood_and_the_filters_follow_the_address() {
    let table = table_of(Turns::Multi12);
    let pages = factory_pages(table, None, Some(SERIAL)).unwrap();
    let mut params = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
    let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &params.load());
    let d = Instant::from_micros(delay_us(SERIAL));
    node.poll(Instant::ZERO);
    let g0 = od_core::Station::rx_ids_generation(&node);
    assert!(node.filters().iter().all(|f| !f.matches(0x1C06_EF00)), "no CAM21 before an address");
    node.poll(d);
    let out = |node: &mut J1939Node<Wv58mr>| {
        let mut v = Vec::new();
        while let Some(o) = node.next_output() {
            v.push(o);
        }
        v
    };
    assert_eq!(out(&mut node).len(), 1, "the claim");
    assert!(node.filters().iter().any(|f| f.matches(0x1C06_EF00)), "CAM21 to EFh once claimed");
    let masks = od_core::Station::rx_masks(&node);
    assert_eq!(masks.len(), 4);
    assert!(masks.iter().any(|&(id, m)| 0x1C06_EF00 & m == id & m));
    assert!(masks.iter().all(|&(id, m)| 0x1C06_4A00 & m != id & m), "CAM21 to another device");
    assert!(od_core::Station::rx_ids(&node).is_empty());
    // During the 250 ms: no answer to CAM21 nor to a Request for EPOS.
    node.on_frame(&ext(0x1C06_EF00, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), d.add_millis(100));
    node.on_frame(&ext(0x18EA_EF00, &[0x5F, 0xFC, 0x00]), d.add_millis(100));
    assert!(out(&mut node).is_empty());
    node.poll(d.add_millis(250));
    assert_ne!(od_core::Station::rx_ids_generation(&node), g0, "the filters change when the claim stands");
    node.on_frame(&ext(0x1C06_EF00, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), d.add_millis(260));
    let frames: Vec<Frame> = out(&mut node)
        .into_iter()
        .filter_map(|o| match o {
            od_core::Output::Frame(f) => Some(f),
            _ => None,
        })
        .collect();
    assert!(frames.iter().any(|f| raw_id(f) == 0x1C05_00EF));
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Any frames at any times: the node never panics, and everything it sends comes from
        /// its claimed address, or is a claim (Cannot Claim from FEh).
        #[test]
        fn any_bus_input_is_survived(
            frames in proptest::collection::vec(
                (any::<u32>(), proptest::collection::vec(any::<u8>(), 0..=8), 0u64..400_000, any::<bool>()),
                1..60,
            )
        ) {
            let table = table_of(Turns::Multi12);
            let pages = factory_pages(table, None, Some(SERIAL)).unwrap();
            let mut params = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
            let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &params.load());
            let mut t = Instant::ZERO;
            for (id, data, dt, aimed) in frames {
                t = t.add_micros(dt);
                // Half of them aimed at the device's own groups, to get past the parser.
                let id = if aimed { (id & 0x1C00_00FF) | [0x06EF00, 0xEAEF00, 0xEEFF00, 0xEAFF00][(id >> 8) as usize & 3] } else { id & 0x1FFF_FFFF };
                node.on_frame(&Frame::new(CanId::Ext(id), &data), t);
                node.poll(t);
                while let Some(o) = node.next_output() {
                    match o {
                        od_core::Output::Frame(f) => {
                            let sa = raw_id(&f) & 0xFF;
                            let claim = (raw_id(&f) >> 8) & 0x3FF00 == 0xEE00;
                            prop_assert!(claim || node.source_address().map(|a| a.0 as u32) == Some(sa) || sa == 0xEF, "{:08X}", raw_id(&f));
                        }
                        od_core::Output::Store(_) => node.store_done(Ok(()), t),
                        od_core::Output::SetBitrate(_) => {}
                    }
                }
            }
        }
    }
}

/// Found by the J1939 invariant proptest: a client abort (from any master) while a 1010h save
/// waits for its store took over the waiting answer's destination, so the save's CAM11 went to
/// the master that aborted, not to the one that asked for the save. The answer goes to the
/// save's requester.
#[test]
fn a_save_is_answered_to_its_requester_after_another_masters_abort() {
    use od_core::node::Output;
    let table = table_of(Turns::Multi12);
    let pages = factory_pages(table, None, Some(SERIAL)).unwrap();
    let mut flash = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
    let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &flash.load());
    let mut now = Instant::ZERO;
    while let Some(t) = node.next_deadline().filter(|t| *t <= Instant::from_millis(500)) {
        now = t.max(now);
        node.poll(now);
    }
    while node.next_output().is_some() {}
    assert_eq!(node.source_address(), Some(EF));
    // Master BAh asks for the save; master 00h aborts a transfer of its own meanwhile.
    node.on_frame(&ext(0x1C06_EFBA, &[0x23, 0x10, 0x10, 0x02, b's', b'a', b'v', b'e']), now);
    let Some(Output::Store(mask)) = node.next_output() else { panic!("no store") };
    node.on_frame(&ext(0x1C06_EF00, &[0x80, 0, 0, 0, 0, 0, 0, 0]), now);
    assert_eq!(node.next_output(), None, "a client abort has no answer");
    flash.save(node.context(), mask).unwrap();
    node.store_done(Ok(()), now);
    assert_eq!(
        node.next_output(),
        Some(Output::Frame(ext(0x1C05_BAEF, &[0x60, 0x10, 0x10, 0x02, 0, 0, 0, 0]))),
        "the save's answer goes to BAh"
    );
}

/// Found by the power-cut sweep: a parameter flash holding no valid image (zeroed, corrupt)
/// booted the WV58MR on its defaults without a word, where every device reports it by EMCY
/// 6300h after its boot-up (D-STO-8). On J1939 it goes out once the claim stood, with 1001h
/// bit 0, and it is in 1003h.
#[test]
fn a_corrupt_parameter_flash_is_reported_by_emcy_6300h_once_the_claim_stood() {
    use od_core::node::Output;
    use od_core::storage::Loaded;
    let table = table_of(Turns::Multi12);
    let mut flash = ParamFlash::new(RamFlash::from_bytes(vec![0; 4 * 1024]), REGION, identity(table));
    let loaded = flash.load();
    assert_eq!(loaded, Loaded::Invalid);
    let mut node = J1939Node::boot(Wv58mr::new(Turns::Multi12), &loaded);
    let mut now = Instant::ZERO;
    let mut sent = Vec::new();
    while let Some(t) = node.next_deadline().filter(|t| *t <= Instant::from_millis(500)) {
        now = t.max(now);
        node.poll(now);
        while let Some(o) = node.next_output() {
            if let Output::Frame(f) = o {
                sent.push((now, f));
            }
        }
    }
    let stood = sent.iter().find(|(_, f)| raw_id(f) >> 8 & 0x3FFFF == 0xFC5F).expect("EPOS once the claim stood").0;
    let emcy: Vec<_> = sent.iter().filter(|(_, f)| raw_id(f) == 0x04FC_68EF).collect();
    assert_eq!(emcy.len(), 1, "{sent:02X?}");
    assert_eq!(emcy[0].0, stood, "EMCY 6300h when the claim stood");
    assert_eq!(emcy[0].1.payload(), &[0x00, 0x63, 0x01, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(node.context().od.value(0x1003, 1), Some(0x6300));
}

/// A segmented CAM21 download to 3000h takes effect as an expedited one does (D-J1939-28): the
/// value lands with the last segment, and the cyclic groups follow it from there (the random
/// proptest found Proprietary B still sent at the priority 3000h.04 held before).
#[test]
fn a_segmented_write_to_3000h_reaches_the_cyclic_groups() {
    let (mut bus, _, _) = setup(SERIAL);
    claimed(&mut bus, SERIAL);
    // 3000h.04 (Proprietary B's priority) := 2, segmented: initiate (1 byte), one last segment.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x21, 0x00, 0x30, 0x04, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!(a, [0x60, 0x00, 0x30, 0x04, 0x00, 0x00, 0x00, 0x00]);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x0D, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x20);
    assert_eq!(cam_read(&mut bus, EF, MASTER, 0x3000, 4)[4], 0x02);
    // 3000h.01 := 100 ms, segmented too: Proprietary B is sent at once, then every 100 ms, at
    // priority 2.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x21, 0x00, 0x30, 0x01, 0x02, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x0B, 0x64, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x20);
    let t = bus.now();
    bus.advance(250);
    let b = of_group(&bus.drain(), Pgn::PROPRIETARY_B);
    assert_eq!(b.iter().map(|s| s.at.micros_since(t)).collect::<Vec<_>>(), [0, 100_000, 200_000]);
    assert!(b.iter().all(|s| raw_id(&s.frame) == 0x08FF_AAEF), "{b:02X?}");
    // A Request for it is answered at that priority too.
    bus.send(Request { pgn: Pgn::PROPRIETARY_B }.frame(EF, MASTER));
    bus.advance(1);
    let b = of_group(&bus.drain(), Pgn::PROPRIETARY_B);
    assert_eq!(b.iter().map(|s| raw_id(&s.frame)).collect::<Vec<_>>(), [0x08FF_AAEF]);
    // 3000h.01 := 0, segmented: Proprietary B stops.
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x21, 0x00, 0x30, 0x01, 0x02, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x60);
    let (_, a) = cam_exchange(&mut bus, EF, MASTER, [0x0B, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(a[0], 0x20);
    bus.drain();
    bus.advance(500);
    assert!(of_group(&bus.drain(), Pgn::PROPRIETARY_B).is_empty(), "0 switches it off");
}
