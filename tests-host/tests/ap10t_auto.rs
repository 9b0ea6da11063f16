//! The AP10T's auto functions and its parameter storage on the virtual bus, with the display's
//! parameters in a flash: auto-baud (manual 4.6.1), Auto-ID (4.6.2, Table 15 = digest E5),
//! the key menu's node-ID, 1010h/1011h (E8, D10, D11, Table 3/4) and power cycles.

use od_core::autobaud::DWELL_MS;
use od_core::devices::ap10t::table::TABLE;
use od_core::devices::ap10t::Key;
use od_core::storage::{identity, ParamFlash, Region};
use od_core::{Bitrate, Frame, Instant};
use tests_host::ap10t::Display;
use tests_host::bus::{Bus, Sender};
use tests_host::flash::RamFlash;

const REGION: Region = Region { offset: 0, pages: 4 };

/// A factory AP10T (blank flash) switched on; returns its number.
fn factory(bus: &mut Bus) -> usize {
    let params = ParamFlash::new(RamFlash::new(4), REGION, identity(TABLE));
    bus.add_with_flash(params, Display::boot)
}

fn display(bus: &mut Bus, n: usize) -> &mut Display {
    bus.station(n).as_any_mut().and_then(|a| a.downcast_mut::<Display>()).expect("an AP10T")
}

fn press(bus: &mut Bus, n: usize, key: Key) {
    let now = bus.now();
    display(bus, n).press(key, now);
    display(bus, n).release(key, now);
    bus.advance(0);
}

fn rows(bus: &mut Bus, n: usize) -> [String; 2] {
    let now = bus.now();
    display(bus, n).rows(now)
}

#[track_caller]
fn sdo(bus: &mut Bus, id: u8, req: [u8; 8], resp: [u8; 8]) {
    bus.send(Frame::std(0x600 + id as u16, &req));
    bus.expect(0x580 + id as u16, &resp);
}

/// The master's traffic: NMT "enter PRE-OPERATIONAL" to all nodes every 100 ms until a node
/// boots up (at most `ms`); returns the boot-up frame's sender and time.
fn traffic_until_boot_up(bus: &mut Bus, ms: u64) -> Option<(usize, Instant)> {
    for _ in 0..ms / 100 {
        bus.send(Frame::std(0x000, &[0x80, 0x00]));
        bus.advance(100);
        if let Some(seen) = bus.recv() {
            let Sender::Node(n) = seen.from else { unreachable!() };
            assert_eq!(seen.frame, Frame::std(0x77D, &[0x00]), "only a boot-up");
            return Some((n, seen.at));
        }
    }
    None
}

/// Master traffic (NMT to node 7Eh, nobody) every 100 ms for up to ten dwell times; the
/// boot-up on `id` must come.
fn traffic_until_boot_up_as(bus: &mut Bus, id: u16) {
    for _ in 0..10 * DWELL_MS / 100 {
        bus.send(Frame::std(0x000, &[0x80, 0x7E]));
        bus.advance(100);
        if let Some(seen) = bus.recv() {
            assert_eq!(seen.frame, Frame::std(id, &[0x00]));
            return;
        }
    }
    panic!("no boot-up");
}

#[test]
fn a_factory_display_joins_a_250_kbit_bus_silently() {
    let mut bus = Bus::new();
    bus.set_bitrate(Bitrate::K250);
    let n = factory(&mut bus);
    // Silent while nobody talks, whatever the rate it tries; the controller runs silent.
    assert!(display(&mut bus, n).node().listen_only());
    bus.advance(10 * DWELL_MS);
    bus.expect_silence();
    assert!(bus.log.is_empty());
    // With traffic it finds 250 kbit/s and boots up there, and answers.
    let (from, _) = traffic_until_boot_up(&mut bus, 10 * DWELL_MS).expect("detected");
    assert_eq!(from, n);
    assert_eq!(bus.node_bitrate(n), Bitrate::K250);
    assert!(!display(&mut bus, n).node().listen_only());
    // Before the boot-up nothing came from the display.
    assert!(bus.log.iter().filter(|s| s.from == Sender::Node(n)).count() == 1);
    // 5F0Ah.03 reads the detected rate (code 2); a save keeps it: the next power-on needs no
    // traffic.
    sdo(&mut bus, 0x7D, [0x40, 0x0A, 0x5F, 0x03, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x03, 0x02, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x04, 0, 0, 0, 0]);
    bus.power_cycle(n);
    bus.expect(0x77D, &[0x00]);
    assert_eq!(bus.node_bitrate(n), Bitrate::K250);
}

#[test]
fn without_a_save_the_next_power_on_detects_again() {
    let mut bus = Bus::new();
    bus.set_bitrate(Bitrate::K800);
    let n = factory(&mut bus);
    let (_, at) = traffic_until_boot_up(&mut bus, 10 * DWELL_MS).expect("detected");
    // 800 kbit/s is the fourth rate tried (125, 250, 500, 800).
    assert!(at >= Instant::from_millis(3 * DWELL_MS) && at < Instant::from_millis(4 * DWELL_MS + 100), "{at:?}");
    bus.power_cycle(n);
    bus.advance(100);
    bus.expect_silence();
    assert!(traffic_until_boot_up(&mut bus, 10 * DWELL_MS).is_some());
}

/// A factory display detected on a 500 kbit/s bus, past its display test.
fn detected_at_500() -> (Bus, usize) {
    let mut bus = Bus::new();
    let n = factory(&mut bus);
    traffic_until_boot_up(&mut bus, 10 * DWELL_MS).expect("detected");
    bus.advance(1000);
    (bus, n)
}

#[test]
fn e5_auto_id_with_the_key_press() {
    let mut bus = Bus::new();
    let a = factory(&mut bus);
    let b = factory(&mut bus);
    for _ in 0..2 {
        traffic_until_boot_up(&mut bus, 10 * DWELL_MS).expect("detected");
    }
    bus.advance(1000);
    // E5a: the master writes 5F0Ah.02 := 05h on 67Dh; both factory displays show "New ID" and
    // neither answers yet.
    bus.send(Frame::std(0x67D, &[0x2F, 0x0A, 0x5F, 0x02, 0x05, 0x00, 0x00, 0x00]));
    bus.advance(1000);
    bus.expect_silence();
    assert_eq!(rows(&mut bus, a)[0], "New ID");
    assert_eq!(rows(&mut bus, b)[0], "New ID");
    // Other keys do nothing; E5b: the Auto-ID key on display b.
    press(&mut bus, b, Key::Front);
    bus.expect_silence();
    press(&mut bus, b, Key::Star);
    // E5c: the SDO answer on 5FDh; E5d: the boot-up with the new node-ID.
    bus.expect(0x5FD, &[0x60, 0x0A, 0x5F, 0x02, 0, 0, 0, 0]);
    bus.expect(0x705, &[0x00]);
    bus.expect_silence();
    assert_eq!(rows(&mut bus, b)[0], "---");
    assert_eq!(rows(&mut bus, a)[0], "New ID", "all other devices do not react");
    // The master resets all nodes: a's prompt ends, it boots up as 7Dh again.
    bus.send(Frame::std(0x000, &[0x81, 0x00]));
    let mut boot = [bus.recv().unwrap().frame, bus.recv().unwrap().frame];
    boot.sort_by_key(|f| f.id);
    assert_eq!(boot, [Frame::std(0x705, &[0]), Frame::std(0x77D, &[0])]);
    bus.advance(1000);
    assert_eq!(rows(&mut bus, a)[0], "---");
    // The new node-ID was stored: it survives a power cycle (the rate was not: auto again).
    bus.power_cycle(b);
    bus.advance(100);
    bus.expect_silence();
    traffic_until_boot_up_as(&mut bus, 0x705);
    sdo(&mut bus, 5, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x01, 0x05, 0, 0, 0]);
}

#[test]
fn e5e_an_illegal_id_aborts_the_auto_id() {
    let (mut bus, n) = detected_at_500();
    for id in [0x00, 0x80, 0xFF] {
        sdo(&mut bus, 0x7D, [0x2F, 0x0A, 0x5F, 0x02, id, 0, 0, 0], [0x80, 0x0A, 0x5F, 0x02, 0x30, 0x00, 0x09, 0x06]);
        assert_eq!(rows(&mut bus, n)[0], "---");
    }
}

#[test]
fn a_display_with_another_node_id_answers_the_auto_id_write_at_once() {
    let (mut bus, n) = detected_at_500();
    sdo(&mut bus, 0x7D, [0x2F, 0x0A, 0x5F, 0x01, 0x09, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x82, 0x7D]));
    bus.expect(0x709, &[0x00]);
    sdo(&mut bus, 9, [0x2F, 0x0A, 0x5F, 0x02, 0x05, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x02, 0, 0, 0, 0]);
    assert_eq!(rows(&mut bus, n)[0], "---");
}

#[test]
fn the_key_menu_sets_the_node_id_and_keeps_it() {
    let (mut bus, n) = detected_at_500();
    // "←" shows ID and baud rate, "←" again opens the list; "*" opens ID; enter 007 (from
    // 125: units 5 → 7 by two "↑", tens 2 → 0 by eight "↑", hundreds 1 → 0 by nine "↑").
    press(&mut bus, n, Key::Left);
    assert_eq!(rows(&mut bus, n), ["ID 125", "500"]);
    press(&mut bus, n, Key::Left);
    assert_eq!(rows(&mut bus, n), ["ID", "125"]);
    press(&mut bus, n, Key::Star);
    for (presses, next) in [(2, true), (8, true), (9, false)] {
        for _ in 0..presses {
            press(&mut bus, n, Key::Up);
        }
        if next {
            press(&mut bus, n, Key::Left);
        }
    }
    press(&mut bus, n, Key::Star);
    assert_eq!(rows(&mut bus, n), ["ID", "7"]);
    press(&mut bus, n, Key::Front);
    // Adopted at the next initialisation, kept without a 1010h save.
    bus.expect_silence();
    sdo(&mut bus, 0x7D, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x01, 0x07, 0, 0, 0]);
    bus.power_cycle(n);
    // The node-ID alone was kept: the rate is detected again (D-AP-16).
    bus.expect_silence();
    traffic_until_boot_up_as(&mut bus, 0x707);
}

#[test]
fn d10_d11_store_restore_bus_parameters_power_cycle() {
    let (mut bus, n) = detected_at_500();
    // 5F11h := 2 (manufacturer), 1017h := 1000 (a bus parameter), 5F0Ah.01 := 10; D10 save all.
    sdo(&mut bus, 0x7D, [0x2F, 0x11, 0x5F, 0x00, 0x02, 0, 0, 0], [0x60, 0x11, 0x5F, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x2F, 0x0A, 0x5F, 0x01, 0x0A, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    // Store → power cycle → kept: node 10 at 500 kbit/s at once.
    bus.power_cycle(n);
    bus.expect(0x70A, &[0x00]);
    bus.advance(1000);
    bus.expect(0x70A, &[0x7F]);
    sdo(&mut bus, 10, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x02, 0, 0, 0]);
    // 1011h sub 2, "only bus parameters" (Table 4): node-ID, baud rate, heartbeat; not 5F11h.
    sdo(&mut bus, 10, [0x23, 0x11, 0x10, 0x02, 0x6C, 0x6F, 0x61, 0x64], [0x60, 0x11, 0x10, 0x02, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x81, 0x0A]));
    bus.expect(0x77D, &[0x00]);
    bus.advance(2000);
    bus.expect_silence();
    sdo(&mut bus, 0x7D, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x02, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x40, 0x0A, 0x5F, 0x03, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x03, 0x00, 0, 0, 0]);
    // Not saved: a power cycle brings the stored ones back.
    bus.power_cycle(n);
    bus.expect(0x70A, &[0x00]);
    // D11: restore all, reset, save: factory settings for good (auto-baud at the next power-on).
    sdo(&mut bus, 10, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64], [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x81, 0x00]));
    bus.expect(0x77D, &[0x00]);
    sdo(&mut bus, 0x7D, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x00, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    bus.power_cycle(n);
    bus.advance(100);
    bus.expect_silence();
    assert!(traffic_until_boot_up(&mut bus, 10 * DWELL_MS).is_some());
}

#[test]
fn menu_code_011102_restores_all_but_the_bus_parameters_and_keeps_them() {
    let (mut bus, n) = detected_at_500();
    sdo(&mut bus, 0x7D, [0x2F, 0x11, 0x5F, 0x00, 0x03, 0, 0, 0], [0x60, 0x11, 0x5F, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 0x7D, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    // CODE 011102: list, "↑" twice to CODE, "*" opens it; digits from the right: 2, 0, 1, 1, 1, 0.
    press(&mut bus, n, Key::Left);
    press(&mut bus, n, Key::Left);
    press(&mut bus, n, Key::Up);
    press(&mut bus, n, Key::Up);
    assert_eq!(rows(&mut bus, n)[0], "CODE");
    press(&mut bus, n, Key::Star);
    for (i, digit) in [2, 0, 1, 1, 1, 0].into_iter().enumerate() {
        for _ in 0..digit {
            press(&mut bus, n, Key::Up);
        }
        if i < 5 {
            press(&mut bus, n, Key::Left);
        }
    }
    press(&mut bus, n, Key::Star);
    // The node re-initialises (Reset Node) with the restored values.
    bus.expect(0x77D, &[0x00]);
    bus.advance(2000);
    bus.expect(0x77D, &[0x7F]);
    bus.expect(0x77D, &[0x7F]);
    sdo(&mut bus, 0x7D, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x00, 0, 0, 0]);
    // ... and kept: after a power cycle too (the heartbeat, a bus parameter, stays 1000 ms).
    bus.power_cycle(n);
    bus.expect(0x77D, &[0x00]);
    bus.advance(1000);
    bus.expect(0x77D, &[0x7F]);
    sdo(&mut bus, 0x7D, [0x40, 0x11, 0x5F, 0x00, 0, 0, 0, 0], [0x4F, 0x11, 0x5F, 0x00, 0x00, 0, 0, 0]);
}
