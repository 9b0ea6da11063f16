//! AP10T scenarios on the virtual bus, byte for byte: the manual's printed examples (digest
//! 6.1 E1-E10, with the copy errors of E3a/E4b corrected as §7 A14 says) and the derived
//! vectors D1-D30 of digest 6.2, through the whole node (dictionary, services, panel), with the
//! screen read as text.

use od_core::devices::ap10t::Key;
use od_core::node::BusEvent;
use od_core::{Bitrate, CanId, Frame, Instant};
use tests_host::ap10t::Display;
use tests_host::bus::Bus;

/// A configured AP10T with node-ID `id` at 500 kbit/s, after its boot-up.
fn ap10t(id: u8) -> Bus {
    let mut bus = Bus::new();
    bus.add(Display::configured(id, Bitrate::K500));
    bus.expect(0x700 + id as u16, &[0x00]);
    bus.expect_silence();
    // Past the power-up display test (D-AP-12), during which keys do nothing.
    bus.advance(1000);
    bus
}

fn display(bus: &mut Bus, n: usize) -> &mut Display {
    bus.station(n).as_any_mut().and_then(|a| a.downcast_mut::<Display>()).expect("an AP10T")
}

fn press(bus: &mut Bus, n: usize, key: Key) {
    let now = bus.now();
    display(bus, n).press(key, now);
    bus.advance(0);
}

fn release(bus: &mut Bus, n: usize, key: Key) {
    let now = bus.now();
    display(bus, n).release(key, now);
    bus.advance(0);
}

fn rows(bus: &mut Bus, n: usize, at: Instant) -> [String; 2] {
    display(bus, n).rows(at)
}

#[track_caller]
fn sdo(bus: &mut Bus, id: u8, req: [u8; 8], resp: [u8; 8]) {
    bus.send(Frame::std(0x600 + id as u16, &req));
    bus.expect(0x580 + id as u16, &resp);
}

#[track_caller]
fn abort(bus: &mut Bus, id: u8, req: [u8; 8], code: u32) {
    let c = code.to_le_bytes();
    sdo(bus, id, req, [0x80, req[1], req[2], req[3], c[0], c[1], c[2], c[3]]);
}

fn start(bus: &mut Bus, id: u8) {
    bus.send(Frame::std(0x000, &[0x01, id]));
}

/// The first instant of the blink period's lit half at or after the bus's time.
fn lit(bus: &Bus) -> Instant {
    let t = bus.now().as_millis();
    Instant::from_millis(t - t % 1000 + 1000 + 100)
}

fn dark(bus: &Bus) -> Instant {
    lit(bus).add_millis(500)
}

#[test]
fn e1_e2_nmt_and_boot_up() {
    let mut bus = ap10t(0x7D);
    // E2: boot-up 77D 00 (checked by `ap10t`). D3: heartbeat 7Fh in PRE-OPERATIONAL.
    sdo(&mut bus, 0x7D, [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    bus.advance(1000);
    bus.expect(0x77D, &[0x7F]);
    // E1a / D1: start → OPERATIONAL (05), E1b stop (04), E1c pre-operational (7F).
    for (cmd, state) in [(0x01, 0x05), (0x02, 0x04), (0x80, 0x7F)] {
        bus.send(Frame::std(0x000, &[cmd, 0x7D]));
        bus.advance(1000);
        bus.expect(0x77D, &[state]);
    }
    // E1d / D2: reset node (all nodes) → boot-up; E1e reset communication → boot-up.
    for cmd in [0x81, 0x82] {
        bus.send(Frame::std(0x000, &[cmd, 0x00]));
        bus.expect(0x77D, &[0x00]);
    }
    // Another node's command changes nothing.
    bus.send(Frame::std(0x000, &[0x01, 0x05]));
    bus.expect_silence();
}

#[test]
fn d4_d5_node_guarding_toggles() {
    let mut bus = ap10t(0x7D);
    for reply in [0x7F, 0xFF, 0x7F] {
        bus.send(Frame::remote(CanId::Std(0x77D), 1));
        bus.expect(0x77D, &[reply]);
    }
    start(&mut bus, 0x7D);
    bus.send(Frame::remote(CanId::Std(0x77D), 1));
    bus.expect(0x77D, &[0x85]);
}

#[test]
fn e3_read_the_decimal_places_of_node_1() {
    let mut bus = ap10t(1);
    // "The current value is 2".
    sdo(&mut bus, 1, [0x2F, 0x11, 0x5F, 0x00, 0x02, 0, 0, 0], [0x60, 0x11, 0x5F, 0x00, 0, 0, 0, 0]);
    // E3a as corrected (A14: the printed 03 60 is a copy error), E3b as printed.
    sdo(&mut bus, 1, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x02, 0, 0, 0]);
    // The display shows numbers with two decimal places.
    start(&mut bus, 1);
    bus.send(Frame::std(0x201, &[0x39, 0x30, 0, 0, 0, 0, 0x04, 0x04]));
    let t = lit(&bus);
    assert_eq!(rows(&mut bus, 0, t), ["123.45", "---"]);
    // D18: 5 decimal places are out of range.
    abort(&mut bus, 1, [0x2F, 0x11, 0x5F, 0x00, 0x05, 0, 0, 0], 0x0609_0030);
}

#[test]
fn e4_turn_the_display_of_node_1() {
    let mut bus = ap10t(1);
    // E4a as printed; E4b as corrected (A14: it echoes the request's index and sub-index).
    sdo(&mut bus, 1, [0x2F, 0x12, 0x5F, 0x01, 0x01, 0x00, 0x00, 0x00], [0x60, 0x12, 0x5F, 0x01, 0, 0, 0, 0]);
    let t = lit(&bus);
    assert!(display(&mut bus, 0).view(t).screen.rotated);
    sdo(&mut bus, 1, [0x40, 0x12, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x12, 0x5F, 0x01, 0x01, 0, 0, 0]);
}

#[test]
fn e9_d6_d8_identity_and_strings() {
    let mut bus = ap10t(0x7D);
    // D7: 1000h = 00000196h (A11: not the printed 96 01 05 00).
    sdo(&mut bus, 0x7D, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x00, 0x00]);
    sdo(&mut bus, 0x7D, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0x00, 0x00]);
    // 1008h: expedited only, the four bytes of the manual's table "AP10" (A12).
    sdo(&mut bus, 0x7D, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x08, 0x10, 0x00, 0x41, 0x50, 0x31, 0x30]);
    sdo(&mut bus, 0x7D, [0x40, 0x09, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x09, 0x10, 0x00, 0x56, 0x30, 0x30, 0x31]);
    sdo(&mut bus, 0x7D, [0x40, 0x0A, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x0A, 0x10, 0x00, 0x56, 0x31, 0x30, 0x30]);
    sdo(&mut bus, 0x7D, [0x40, 0x07, 0x65, 0x00, 0, 0, 0, 0], [0x43, 0x07, 0x65, 0x00, 0x02, 0x03, 0x2D, 0x01]);
    // D9: node-ID 125.
    sdo(&mut bus, 0x7D, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x01, 0x7D, 0, 0, 0]);
    // Sensor type 3, "no sensor".
    sdo(&mut bus, 0x7D, [0x40, 0x1B, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x1B, 0x5F, 0x01, 0x03, 0, 0, 0]);
}

#[test]
fn d12_d17_sdo_answers_and_refusals() {
    let mut bus = ap10t(0x7D);
    // D12: 1010h sub 1 reads 1.
    sdo(&mut bus, 0x7D, [0x40, 0x10, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x10, 0x10, 0x01, 0x01, 0, 0, 0]);
    // D13 / D14: heartbeat 1000 ms accepted, 5 ms refused.
    sdo(&mut bus, 0x7D, [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    abort(&mut bus, 0x7D, [0x2B, 0x17, 0x10, 0x00, 0x05, 0x00, 0, 0], 0x0609_0030);
    // D15: write to a read-only object; D16: no object 2000h; D17: 1400h sub 4 is not used.
    abort(&mut bus, 0x7D, [0x23, 0x00, 0x10, 0x00, 0, 0, 0, 0], 0x0601_0002);
    abort(&mut bus, 0x7D, [0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0], 0x0602_0000);
    abort(&mut bus, 0x7D, [0x40, 0x00, 0x14, 0x04, 0, 0, 0, 0], 0x0609_0011);
    abort(&mut bus, 0x7D, [0x40, 0x00, 0x18, 0x06, 0, 0, 0, 0], 0x0609_0011);
    abort(&mut bus, 0x7D, [0x40, 0x1B, 0x5F, 0x02, 0, 0, 0, 0], 0x0609_0011);
    // 5F1Dh: "SDO access to 5F1D is not supported" (A24): 06010000h, read and write.
    abort(&mut bus, 0x7D, [0x40, 0x1D, 0x5F, 0x01, 0, 0, 0, 0], 0x0601_0000);
    abort(&mut bus, 0x7D, [0x23, 0x1D, 0x5F, 0x03, 0, 0, 0, 0], 0x0601_0000);
    // 5F0Ch and 5F19h are written by PDOs only.
    abort(&mut bus, 0x7D, [0x2B, 0x0C, 0x5F, 0x00, 0, 0, 0, 0], 0x0601_0002);
    // External heartbeat 1..9 ms refused (A34).
    abort(&mut bus, 0x7D, [0x2B, 0x09, 0x5F, 0x01, 0x09, 0x00, 0, 0], 0x0609_0030);
    // Expedited only: a segmented download and an unsized expedited one abort (D-AP-21).
    abort(&mut bus, 0x7D, [0x21, 0x17, 0x10, 0x00, 0x02, 0, 0, 0], 0x0504_0001);
    abort(&mut bus, 0x7D, [0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], 0x0504_0001);
    // Not answered in STOPPED.
    bus.send(Frame::std(0x000, &[0x02, 0x7D]));
    bus.send(Frame::std(0x67D, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    bus.expect_silence();
}

#[test]
fn d19_d21_tpdo1_on_its_event_timer() {
    let mut bus = ap10t(0x7D);
    // D19: 1800h.05 = 100 ms; 6200h reads the same.
    sdo(&mut bus, 0x7D, [0x2B, 0x00, 0x18, 0x05, 0x64, 0x00, 0, 0], [0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x40, 0x00, 0x62, 0x00, 0, 0, 0, 0], [0x4B, 0x00, 0x62, 0x00, 0x64, 0, 0, 0]);
    // RPDOs are not processed in PRE-OPERATIONAL.
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    let t = lit(&bus);
    assert_eq!(rows(&mut bus, 0, t), ["---", "---"]);
    start(&mut bus, 0x7D);
    // D20: SP1 = 12345, CW 0004h: row 1 "12345" flashing, left LED red.
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, t), ["12345", "---"]);
    assert_eq!(rows(&mut bus, 0, d), ["", "---"]);
    let v = display(&mut bus, 0).view(t);
    assert!(v.leds.left.red && !v.leds.left.green && !v.leds.right.red);
    // D21: the first TPDO1 one period after the start.
    bus.advance(100);
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
    // 6200h = 0 stops it.
    sdo(&mut bus, 0x7D, [0x2B, 0x00, 0x62, 0x00, 0x00, 0x00, 0, 0], [0x60, 0x00, 0x62, 0x00, 0, 0, 0, 0]);
    bus.advance(500);
    bus.expect_silence();
}

#[test]
fn d22_d23_acknowledged_by_key_then_by_the_master() {
    let mut bus = ap10t(0x7D);
    start(&mut bus, 0x7D);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    // D22: the front key acknowledges; SW 0025h while held, 0024h after.
    press(&mut bus, 0, Key::Front);
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x25, 0x00]);
    release(&mut bus, 0, Key::Front);
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x24, 0x00]);
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, d), ["12345", "---"], "steady once acknowledged");
    let v = display(&mut bus, 0).view(t);
    assert!(v.leds.left.green && !v.leds.left.red);
    // D23: CW 0504h (acknowledged by the bus, guarding bit) → SW 0124h.
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x05]));
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x24, 0x01]);
    // 5F0Ch and 5F19h read back over SDO.
    sdo(&mut bus, 0x7D, [0x40, 0x0C, 0x5F, 0x00, 0, 0, 0, 0], [0x4B, 0x0C, 0x5F, 0x00, 0x04, 0x05, 0, 0]);
    sdo(&mut bus, 0x7D, [0x40, 0x19, 0x5F, 0x00, 0, 0, 0, 0], [0x4B, 0x19, 0x5F, 0x00, 0x24, 0x01, 0, 0]);
    sdo(&mut bus, 0x7D, [0x40, 0x16, 0x5F, 0x03, 0, 0, 0, 0], [0x43, 0x16, 0x5F, 0x03, 0x39, 0x30, 0, 0]);
}

#[test]
fn d24_ascii_and_the_data_identifier_of_rtr_answers() {
    let mut bus = ap10t(0x7D);
    start(&mut bus, 0x7D);
    bus.send(Frame::std(0x27D, &[0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x84, 0x00]));
    let t = lit(&bus);
    assert_eq!(rows(&mut bus, 0, t), ["AP10T", "---"]);
    // An RTR on RPDO1's identifier reads set point 1 back, SW bit 9 = ASCII (D-AP-13).
    bus.send(Frame::remote(CanId::Std(0x27D), 8));
    bus.expect(0x27D, &[0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x04, 0x02]);
    // So does an RTR on TPDO1's identifier; the timer and SYNC TPDOs carry bit 9 = 0.
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x04, 0x02]);
    // RPDO2's RTR answers set point 2 (none).
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0, 0, 0, 0, 0, 0, 0x04, 0x00]);
    bus.send(Frame::remote(CanId::Std(0x37D), 8));
    bus.expect(0x37D, &[0, 0, 0, 0, 0, 0, 0x04, 0x00]);
    // Not in PRE-OPERATIONAL.
    bus.send(Frame::std(0x000, &[0x80, 0x7D]));
    bus.send(Frame::remote(CanId::Std(0x27D), 8));
    bus.expect_silence();
}

#[test]
fn d25_d27_set_point_2_and_the_extended_range() {
    let mut bus = ap10t(0x7D);
    start(&mut bus, 0x7D);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    // D25: SP2 = -5, CW 0204h.
    bus.send(Frame::std(0x37D, &[0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x04, 0x02]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, t), ["12345", "-5"]);
    assert_eq!(rows(&mut bus, 0, d), ["", ""]);
    assert!(display(&mut bus, 0).view(t).leds.right.red);
    // D26: SYNC → TPDO2 with SP2 and SW 0404h.
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x04, 0x04]);
    // D27: -345678, extended range, acknowledged: sign and top digit alternate.
    bus.send(Frame::std(0x37D, &[0xB2, 0xB9, 0xFA, 0xFF, 0x00, 0x00, 0x4C, 0x02]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, t)[1], "-45678");
    assert_eq!(rows(&mut bus, 0, d)[1], "345678");
    // D27b: the same value in the standard range: FULLL (D-AP-3 keeps the acknowledgement).
    bus.send(Frame::std(0x37D, &[0xB2, 0xB9, 0xFA, 0xFF, 0x00, 0x00, 0x04, 0x02]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, t)[1], "FULLL");
    assert_eq!(rows(&mut bus, 0, d)[1], "FULLL");
    // D27c: LED2 red left under control-word control.
    sdo(&mut bus, 0x7D, [0x2F, 0x12, 0x5F, 0x03, 0x00, 0, 0, 0], [0x60, 0x12, 0x5F, 0x03, 0, 0, 0, 0]);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x04]));
    let t = lit(&bus);
    assert!(!display(&mut bus, 0).view(t).leds.left.red);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x44]));
    assert!(display(&mut bus, 0).view(t).leds.left.red);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0xC4]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert!(display(&mut bus, 0).view(t).leds.left.red);
    assert!(!display(&mut bus, 0).view(d).leds.left.red, "blinks with bit 15");
}

#[test]
fn d28_d30_emcy() {
    let mut bus = ap10t(0x7D);
    // The controller's events reach the node through the shell; each EMCY once (E10 layout).
    for (event, frames) in [
        (BusEvent::ErrorPassive, &[[0x20, 0x81, 0x11, 0, 0, 0, 0, 0]][..]),
        (BusEvent::ErrorActive, &[[0x00, 0x00, 0x00, 0, 0, 0, 0, 0]][..]),
        (BusEvent::BusOffRecovered, &[[0x40, 0x81, 0x11, 0, 0, 0, 0, 0], [0x00, 0x00, 0x00, 0, 0, 0, 0, 0]][..]),
    ] {
        let now = bus.now();
        display(&mut bus, 0).bus_event(event, now);
        bus.advance(0);
        for f in frames {
            bus.expect(0x0FD, f);
        }
        bus.expect_silence();
    }
    // 1003h keeps the two errors, the newest in sub 1.
    sdo(&mut bus, 0x7D, [0x40, 0x03, 0x10, 0x00, 0, 0, 0, 0], [0x4F, 0x03, 0x10, 0x00, 0x02, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x40, 0x03, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x03, 0x10, 0x01, 0x40, 0x81, 0, 0]);
    // CODE 200000 shows them on the display (D-AP-23): "←" "←" opens the list, "↑" "↑" CODE,
    // "*" opens it; the sixth digit from the right to 2.
    for key in [Key::Left, Key::Left, Key::Up, Key::Up, Key::Star] {
        press(&mut bus, 0, key);
        release(&mut bus, 0, key);
    }
    for key in [Key::Left, Key::Left, Key::Left, Key::Left, Key::Left, Key::Up, Key::Up, Key::Star] {
        press(&mut bus, 0, key);
        release(&mut bus, 0, key);
    }
    let t = lit(&bus);
    assert_eq!(rows(&mut bus, 0, t), ["1    1", "8140"]);
    press(&mut bus, 0, Key::Up);
    assert_eq!(rows(&mut bus, 0, t), ["2    1", "8120"]);
}

#[test]
fn external_heartbeat_returns_to_pre_operational() {
    let mut bus = ap10t(0x7D);
    // 5F09h.01 = 100 ms, source RPDO (5F09h.02 = 0).
    sdo(&mut bus, 0x7D, [0x2B, 0x09, 0x5F, 0x01, 0x64, 0x00, 0, 0], [0x60, 0x09, 0x5F, 0x01, 0, 0, 0, 0]);
    start(&mut bus, 0x7D);
    for _ in 0..5 {
        bus.advance(60);
        bus.send(Frame::std(0x27D, &[1, 0, 0, 0, 0, 0, 0x04, 0x00]));
    }
    bus.send(Frame::remote(CanId::Std(0x77D), 1));
    bus.expect(0x77D, &[0x05]);
    // No RPDO for 100 ms: PRE-OPERATIONAL.
    bus.advance(99);
    bus.send(Frame::remote(CanId::Std(0x77D), 1));
    bus.expect(0x77D, &[0x85]);
    bus.advance(1);
    bus.send(Frame::remote(CanId::Std(0x77D), 1));
    bus.expect(0x77D, &[0x7F]);
    // Source SYNC: SYNCs keep it OPERATIONAL, RPDOs do not.
    sdo(&mut bus, 0x7D, [0x2F, 0x09, 0x5F, 0x02, 0x01, 0x00, 0, 0], [0x60, 0x09, 0x5F, 0x02, 0, 0, 0, 0]);
    start(&mut bus, 0x7D);
    for _ in 0..5 {
        bus.advance(60);
        bus.send(Frame::std(0x080, &[]));
        bus.expect(0x2FD, &[0, 0, 0, 0, 0, 0, 0x04, 0x00]);
    }
    for _ in 0..2 {
        bus.advance(60);
        bus.send(Frame::std(0x27D, &[1, 0, 0, 0, 0, 0, 0x04, 0x00]));
    }
    bus.send(Frame::remote(CanId::Std(0x77D), 1));
    bus.expect(0x77D, &[0xFF]);
    // Not supervised outside OPERATIONAL: no change in PRE-OPERATIONAL.
    bus.advance(500);
    bus.expect_silence();
}

#[test]
fn panel_parameters_by_sdo_act_at_once() {
    let mut bus = ap10t(0x7D);
    start(&mut bus, 0x7D);
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x02]));
    bus.send(Frame::std(0x37D, &[0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x02]));
    let (t, d) = (lit(&bus), dark(&bus));
    assert_eq!(rows(&mut bus, 0, d), ["", ""]);
    // 5F1Ch.01 = 1: unacknowledged set points steady.
    sdo(&mut bus, 0x7D, [0x2F, 0x1C, 0x5F, 0x01, 0x01, 0, 0, 0], [0x60, 0x1C, 0x5F, 0x01, 0, 0, 0, 0]);
    assert_eq!(rows(&mut bus, 0, d), ["12345", "7"]);
    // 5F0Bh = 1: row 2 off (not stored: 5F0Bh is in no group).
    sdo(&mut bus, 0x7D, [0x2F, 0x0B, 0x5F, 0x00, 0x01, 0, 0, 0], [0x60, 0x0B, 0x5F, 0x00, 0, 0, 0, 0]);
    assert_eq!(rows(&mut bus, 0, t), ["12345", ""]);
    // 5F1Ch sub 0 = 1: only the front key acknowledges; "*" does not.
    sdo(&mut bus, 0x7D, [0x2F, 0x1C, 0x5F, 0x00, 0x01, 0, 0, 0], [0x60, 0x1C, 0x5F, 0x00, 0, 0, 0, 0]);
    press(&mut bus, 0, Key::Star);
    release(&mut bus, 0, Key::Star);
    sdo(&mut bus, 0x7D, [0x40, 0x19, 0x5F, 0x00, 0, 0, 0, 0], [0x4B, 0x19, 0x5F, 0x00, 0x04, 0x04, 0, 0]);
    press(&mut bus, 0, Key::Front);
    sdo(&mut bus, 0x7D, [0x40, 0x19, 0x5F, 0x00, 0, 0, 0, 0], [0x4B, 0x19, 0x5F, 0x00, 0x2D, 0x04, 0, 0]);
    // 5F12h.07/.08 = 0: backlight off.
    sdo(&mut bus, 0x7D, [0x2F, 0x12, 0x5F, 0x07, 0x00, 0, 0, 0], [0x60, 0x12, 0x5F, 0x07, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x2F, 0x12, 0x5F, 0x08, 0x00, 0, 0, 0], [0x60, 0x12, 0x5F, 0x08, 0, 0, 0, 0]);
    let v = display(&mut bus, 0).view(t);
    assert!(!v.backlight.white && !v.backlight.red);
    // Out of range: 06090030h, nothing changes.
    abort(&mut bus, 0x7D, [0x2F, 0x1C, 0x5F, 0x00, 0x03, 0, 0, 0], 0x0609_0030);
    abort(&mut bus, 0x7D, [0x2F, 0x05, 0x20, 0x02, 0x00, 0, 0, 0], 0x0609_0030);
    abort(&mut bus, 0x7D, [0x23, 0x05, 0x20, 0x03, 0x40, 0x42, 0x0F, 0], 0x0609_0030);
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Step {
        Frame { id: u16, rtr: bool, data: Vec<u8> },
        Key { key: usize, down: bool },
        Wait(u64),
    }

    fn step() -> impl Strategy<Value = Step> {
        // Identifiers the display acts on, and some it does not.
        let ids = prop_oneof![
            Just(0x000u16),
            Just(0x080),
            Just(0x1FD),
            Just(0x27D),
            Just(0x2FD),
            Just(0x37D),
            Just(0x67D),
            Just(0x77D),
            0u16..0x800,
        ];
        prop_oneof![
            4 => (ids, any::<bool>(), proptest::collection::vec(any::<u8>(), 0..=8))
                .prop_map(|(id, rtr, data)| Step::Frame { id, rtr, data }),
            2 => (0usize..4, any::<bool>()).prop_map(|(key, down)| Step::Key { key, down }),
            1 => (0u64..3000).prop_map(Step::Wait),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        /// Whatever arrives (frames of any length, RTRs, SDO writes, NMT, keys, time), nothing
        /// panics, and the dictionary's views (5F19h, 5F1Dh) say what the panel holds.
        #[test]
        fn the_dictionary_follows_the_panel(steps in proptest::collection::vec(step(), 1..60)) {
            let mut bus = ap10t(0x7D);
            start(&mut bus, 0x7D);
            for s in steps {
                match s {
                    Step::Frame { id, rtr, data } => {
                        let f = if rtr { Frame::remote(CanId::Std(id), data.len() as u8) } else { Frame::std(id, &data) };
                        bus.send(f);
                    }
                    Step::Key { key, down } => {
                        let key = Key::ALL[key];
                        if down { press(&mut bus, 0, key) } else { release(&mut bus, 0, key) }
                    }
                    Step::Wait(ms) => bus.advance(ms),
                }
                bus.drain();
                let d = display(&mut bus, 0);
                let panel = d.node().device().panel();
                let od = &d.node().core().od;
                prop_assert_eq!(od.value(0x5F19, 0), Some(panel.status_word().bits() as u32));
                let b = panel.set_points().sp[0].bytes;
                prop_assert_eq!(od.value(0x5F1D, 3), Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]])));
                let b = panel.set_points().sp[1].bytes;
                prop_assert_eq!(od.value(0x5F1D, 2), Some(u16::from_le_bytes([b[4], b[5]]) as u32));
            }
        }
    }
}
