//! The AP10T's front panel (`od_core::devices::ap10t::Panel`) as a pure state machine: RPDO data,
//! key presses and parameters in; screen as text, LEDs, backlight, status word and TPDO data out,
//! at given instants of virtual time. The frames are the digest's D20-D27c (section 6.2) byte
//! for byte; the key functions whose symbols the manual lost come from `KEYMAP`, so these tests
//! name keys through it. Decisions in docs/decisions.md, "AP10T".

use od_core::devices::ap10t::keys::AckKeys;
use od_core::devices::ap10t::leds::{Backlight, Bicolour, Leds};
use od_core::devices::ap10t::menu::{DiagEntry, Item, MENU_TIMEOUT_MS};
use od_core::devices::ap10t::{Effect, Key, Mode, Panel, Params, ResetScope, Which, KEYMAP};
use od_core::Instant;

const OFF: Bicolour = Bicolour { green: false, red: false };
const RED: Bicolour = Bicolour { green: false, red: true };
const GREEN: Bicolour = Bicolour { green: true, red: false };

// Digest 6.2, node 7Dh, OPERATIONAL; only the data bytes matter here.
const D20: [u8; 8] = [0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00];
const D23: [u8; 8] = [0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x05];
const D24: [u8; 8] = [0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x84, 0x00];
const D25: [u8; 8] = [0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x04, 0x02];
const D27: [u8; 8] = [0xB2, 0xB9, 0xFA, 0xFF, 0x00, 0x00, 0x4C, 0x02];
const D27B: [u8; 8] = [0xB2, 0xB9, 0xFA, 0xFF, 0x00, 0x00, 0x04, 0x02];

fn ms(t: u64) -> Instant {
    Instant::from_millis(t)
}

/// The two rows as text at `t` ms.
fn rows(p: &Panel, t: u64) -> [String; 2] {
    p.view(ms(t)).screen.rows.map(|r| r.text().as_str().to_owned())
}

/// A press and release at `t` ms.
fn tap(p: &mut Panel, key: Key, t: u64) -> Option<Effect> {
    let e = p.press(key, ms(t));
    p.release(key);
    e
}

#[test]
fn factory_panel_without_set_points() {
    let p = Panel::new(Params::FACTORY);
    assert_eq!(rows(&p, 0), ["---", "---"]);
    let v = p.view(ms(0));
    assert_eq!(v.leds, Leds { left: OFF, right: OFF });
    assert_eq!(v.backlight, Backlight { white: true, red: true });
    assert_eq!(v.screen.rows[1].cells_text(), "   ---");
    assert_eq!(p.status_word().bits(), 0);
    assert_eq!(p.next_change(ms(0)), None, "nothing blinks");
}

#[test]
fn d20_to_d23_number_flashes_until_the_front_key() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    // Row 1 "12345" flashing (lit in the first half of each second), row 2 still "---".
    assert_eq!(rows(&p, 10_100), ["12345", "---"]);
    assert_eq!(rows(&p, 10_600), ["", "---"]);
    assert_eq!(p.view(ms(10_600)).leds, Leds { left: RED, right: OFF });
    assert_eq!(p.next_change(ms(10_100)), Some(ms(10_500)));
    assert_eq!(p.status_word().bits(), 0x0004);
    // D21: the timer TPDO1.
    assert_eq!(p.tpdo(Which::Sp1, false), [0x39, 0x30, 0, 0, 0, 0, 0x04, 0x00]);
    // D22: the front key acknowledges; SW 0025h while held, 0024h after.
    assert_eq!(p.press(Key::Front, ms(10_700)), Some(Effect::Acknowledged));
    assert_eq!(p.status_word().bits(), 0x0025);
    assert_eq!(p.tpdo(Which::Sp1, false)[6..], [0x25, 0x00]);
    p.release(Key::Front);
    assert_eq!(p.status_word().bits(), 0x0024);
    assert_eq!(rows(&p, 10_700), ["12345", "---"], "steady now");
    assert_eq!(p.view(ms(10_700)).leds.left, GREEN);
    assert_eq!(p.next_change(ms(10_700)), None);
    // A second press finds nothing to acknowledge.
    assert_eq!(tap(&mut p, Key::Front, 11_000), None);
    // D23: the guarding bit is mirrored.
    p.receive(Which::Sp1, &D23);
    assert_eq!(p.tpdo(Which::Sp1, false), [0x39, 0x30, 0, 0, 0, 0, 0x24, 0x01]);
}

#[test]
fn d24_ascii_set_point() {
    let mut p = Panel::new(Params { decimals: 3, ..Params::FACTORY });
    p.receive(Which::Sp1, &D24);
    assert_eq!(rows(&p, 0), ["AP10T", "---"], "5F11h does not apply to text");
    assert_eq!(p.view(ms(0)).screen.rows[0].cells_text(), "AP10T ");
    // RTR answer: status word bit 9 = data identifier.
    assert_eq!(p.tpdo(Which::Sp1, true), [0x41, 0x50, 0x31, 0x30, 0x54, 0x20, 0x04, 0x02]);
    assert_eq!(p.tpdo(Which::Sp1, false)[6..], [0x04, 0x00]);
}

#[test]
fn d25_d26_set_point_2_and_one_keystroke_for_both() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    p.receive(Which::Sp2, &D25);
    assert_eq!(rows(&p, 0), ["12345", "-5"]);
    assert_eq!(rows(&p, 500), ["", ""]);
    assert_eq!(p.view(ms(0)).leds, Leds { left: RED, right: RED });
    assert_eq!(p.tpdo(Which::Sp2, false), [0xFB, 0xFF, 0xFF, 0xFF, 0, 0, 0x04, 0x04]);
    // "*" acknowledges too with the factory 5F1Ch sub 0 = 0, both set points at once.
    assert_eq!(tap(&mut p, Key::Star, 600), Some(Effect::Acknowledged));
    assert_eq!(p.view(ms(600)).leds, Leds { left: GREEN, right: GREEN });
    assert_eq!(rows(&p, 600), ["12345", "-5"]);
    assert_eq!(p.status_word().bits(), 0x042C);
}

#[test]
fn d27_extended_range_alternates_once_acknowledged() {
    let mut p = Panel::new(Params::FACTORY);
    // D27: CW 024Ch acknowledges set point 2 by bus and selects the extended range.
    p.receive(Which::Sp2, &D27);
    assert_eq!(rows(&p, 0)[1], "-45678");
    assert_eq!(rows(&p, 500)[1], "345678");
    assert_eq!(rows(&p, 1000)[1], "-45678");
    assert_eq!(p.next_change(ms(0)), Some(ms(500)));
    assert_eq!(p.view(ms(0)).leds.right, GREEN);
    // D27b: the same value in the standard range: FULLL. The value is unchanged, so the
    // acknowledgement stays (a 0 acknowledgement bit withdraws nothing, D-AP-3): steady.
    p.receive(Which::Sp2, &D27B);
    assert_eq!(rows(&p, 0)[1], "FULLL");
    assert_eq!(rows(&p, 500)[1], "FULLL");
    // A new value (-345679), unacknowledged: FULLL flashing.
    p.receive(Which::Sp2, &[0xB1, 0xB9, 0xFA, 0xFF, 0x00, 0x00, 0x04, 0x02]);
    assert_eq!(rows(&p, 0)[1], "FULLL");
    assert_eq!(rows(&p, 500)[1], "");
    // Extended range but not acknowledged (CW 020Ch): still FULLL.
    p.receive(Which::Sp2, &[0xB1, 0xB9, 0xFA, 0xFF, 0, 0, 0x0C, 0x02]);
    assert_eq!(rows(&p, 0)[1], "FULLL");
    assert_eq!(rows(&p, 500)[1], "");
    // Acknowledged by key: the extended display starts.
    assert_eq!(tap(&mut p, Key::Front, 100), Some(Effect::Acknowledged));
    assert_eq!(rows(&p, 100)[1], "-45679");
    assert_eq!(rows(&p, 600)[1], "345679");
}

#[test]
fn d27c_led_by_control_word() {
    let mut lights = Params::FACTORY.lights;
    lights.ack_dependent[1] = false; // 5F12h sub 3 := 0
    let mut p = Panel::new(Params { lights, ..Params::FACTORY });
    p.receive(Which::Sp1, &[0x39, 0x30, 0, 0, 0, 0, 0x04, 0x40]); // CW 4004h
    assert_eq!(p.view(ms(600)).leds.left, RED);
    p.receive(Which::Sp1, &[0x39, 0x30, 0, 0, 0, 0, 0x04, 0xC0]); // CW C004h
    assert_eq!(p.view(ms(100)).leds.left, RED);
    assert_eq!(p.view(ms(600)).leds.left, OFF);
}

#[test]
fn decimal_places_sign_and_range_through_the_panel() {
    let mut p = Panel::new(Params { decimals: 2, steady_unacknowledged: true, ..Params::FACTORY });
    let mut show = |v: i32| {
        let b = v.to_le_bytes();
        p.receive(Which::Sp1, &[b[0], b[1], b[2], b[3], 0, 0, 0x04, 0x00]);
        rows(&p, 600)[0].clone()
    };
    assert_eq!(show(0), "0.00");
    assert_eq!(show(-12345), "-123.45");
    assert_eq!(show(99999), "999.99");
    assert_eq!(show(100000), "FULLL");
    assert_eq!(show(-19999), "-199.99");
    assert_eq!(show(-20000), "FULLL");
    assert_eq!(show(7), "0.07");
}

#[test]
fn row_2_off_and_rotation() {
    let mut p = Panel::new(Params { row2_off: true, rotated: true, ..Params::FACTORY });
    p.receive(Which::Sp1, &[0x39, 0x30, 0, 0, 0, 0, 0x04, 0x06]); // both valid, SP1 acknowledged
    p.receive(Which::Sp2, &[0x07, 0, 0, 0, 0, 0, 0x44, 0x06]); // SP2 = 7, acknowledged
    let v = p.view(ms(0));
    assert_eq!(rows(&p, 0), ["12345", ""], "5F0Bh = 1: row 2 off");
    assert_eq!(v.leds.right, GREEN, "the right LED still shows set point 2");
    assert!(v.screen.rotated);
    let phys = v.screen.physical();
    assert_eq!(phys[1].map(|c| c.ch), *b"54321 ", "the reader's upper row, upside down on the lower");
    assert!(phys[1][0].upside_down);
    assert_eq!(phys[0].map(|c| c.ch), *b"      ");
    p.params.row2_off = false;
    assert_eq!(rows(&p, 0), ["12345", "7"]);
}

#[test]
fn acknowledgement_keys_follow_5f1c_and_the_key_enables() {
    let fresh = |params: Params| {
        let mut p = Panel::new(params);
        p.receive(Which::Sp1, &D20);
        p
    };
    // 5F1Ch sub 0 = 1: only the front key.
    let mut p = fresh(Params { ack_keys: AckKeys::FrontOnly, ..Params::FACTORY });
    assert_eq!(tap(&mut p, Key::Star, 0), None);
    assert_eq!(tap(&mut p, Key::Up, 0), None);
    assert!(!p.set_points().get(Which::Sp1).acknowledged);
    assert_eq!(tap(&mut p, Key::Front, 0), Some(Effect::Acknowledged));
    // 5F1Ch sub 0 = 2: "↑" and "←" (and the front key), not "*".
    let mut p = fresh(Params { ack_keys: AckKeys::ArrowsAndFront, ..Params::FACTORY });
    assert_eq!(tap(&mut p, Key::Star, 0), None);
    assert_eq!(tap(&mut p, Key::Up, 0), Some(Effect::Acknowledged));
    let mut p = fresh(Params { ack_keys: AckKeys::ArrowsAndFront, ..Params::FACTORY });
    assert_eq!(tap(&mut p, Key::Left, 0), Some(Effect::Acknowledged), "acknowledges, no info display");
    assert_eq!(p.mode(ms(0)), Mode::Normal);
    // With nothing to acknowledge "←" is the parameterization key again.
    tap(&mut p, Key::Left, 100);
    assert!(matches!(p.mode(ms(100)), Mode::Info(_)));
    // The key enable of KEYMAP.enabled_by_2003 ("*") switches its acknowledgement off.
    let mut p = fresh(Params { key_enable_2003: false, ..Params::FACTORY });
    assert_eq!(tap(&mut p, KEYMAP.enabled_by_2003, 0), None);
    assert_eq!(tap(&mut p, Key::Front, 0), Some(Effect::Acknowledged), "the front key has no enable");
    let mut p = fresh(Params { key_enable_2004: false, ack_keys: AckKeys::ArrowsAndFront, ..Params::FACTORY });
    assert_eq!(tap(&mut p, KEYMAP.enabled_by_2004, 0), None);
}

#[test]
fn steady_unacknowledged_by_5f1c_sub_1() {
    let mut p = Panel::new(Params { steady_unacknowledged: true, ..Params::FACTORY });
    p.receive(Which::Sp1, &D20);
    assert_eq!(rows(&p, 600), ["12345", "---"]);
    assert_eq!(p.view(ms(600)).leds.left, RED, "still unacknowledged");
    assert_eq!(p.next_change(ms(600)), None);
}

#[test]
fn status_word_reports_every_key_while_held() {
    let mut p = Panel::new(Params::FACTORY);
    for (key, bit) in [(Key::Front, 0), (Key::Left, 13), (Key::Star, 14), (Key::Up, 15)] {
        p.press(key, ms(0));
        assert_eq!(p.status_word().bits(), 1 << bit, "{key:?}");
        p.release(key);
        assert_eq!(p.status_word().bits(), 0);
    }
    // Also in the menu.
    tap(&mut p, KEYMAP.parameterize, 10);
    p.press(KEYMAP.value_input, ms(20));
    assert_eq!(p.status_word().bits().count_ones(), 1);
    assert_eq!(p.status_word().bits() & 1, 0, "a symbol key, not the front key");
}

#[test]
fn parameterization_key_shows_id_and_baud_then_opens_the_menu() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    tap(&mut p, KEYMAP.parameterize, 1_000);
    assert_eq!(rows(&p, 1_000), ["ID 125", "AUTO"]);
    assert_eq!(p.next_change(ms(1_000)), Some(ms(6_000)), "nothing blinks; the key enable time ends");
    // After the key enable time (2005h sub 2 = 5 s) the set points are back, unacknowledged.
    assert_eq!(rows(&p, 6_000), ["12345", "---"]);
    assert_eq!(p.mode(ms(6_000)), Mode::Normal);
    // Twice within the key enable time: the list.
    tap(&mut p, KEYMAP.parameterize, 7_000);
    tap(&mut p, KEYMAP.parameterize, 11_999);
    assert_eq!(p.mode(ms(12_000)), Mode::List(Item::Id));
    assert_eq!(rows(&p, 12_000), ["ID", "125"]);
    tap(&mut p, KEYMAP.value_input, 12_100);
    assert_eq!(rows(&p, 12_100), ["KBAUD", "AUTO"]);
    tap(&mut p, KEYMAP.value_input, 12_200);
    assert_eq!(rows(&p, 12_200), ["CODE", ""]);
    tap(&mut p, KEYMAP.value_input, 12_300);
    assert_eq!(rows(&p, 12_300), ["ID", "125"]);
    // Menu keys do not acknowledge; back leaves the menu.
    assert_eq!(tap(&mut p, KEYMAP.back, 12_400), None);
    assert_eq!(p.mode(ms(12_400)), Mode::Normal);
    assert!(!p.set_points().get(Which::Sp1).acknowledged);
}

#[test]
fn another_key_during_the_info_display_acts_at_the_top_level() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    tap(&mut p, KEYMAP.parameterize, 0);
    assert_eq!(tap(&mut p, Key::Front, 100), Some(Effect::Acknowledged));
    assert_eq!(rows(&p, 100), ["12345", "---"]);
}

#[test]
fn keyboard_configuration_disabled_by_2005() {
    let mut p = Panel::new(Params { config_enable: false, config_delay_s: 2, ..Params::FACTORY });
    tap(&mut p, KEYMAP.parameterize, 0);
    tap(&mut p, KEYMAP.parameterize, 500);
    assert!(matches!(p.mode(ms(500)), Mode::Info(_)), "the info shows, the menu does not open");
    assert_eq!(p.mode(ms(2_000)), Mode::Normal, "2005h sub 2 = 2 s");
}

fn open_menu(p: &mut Panel, t: u64) {
    tap(p, KEYMAP.parameterize, t);
    tap(p, KEYMAP.parameterize, t + 1);
    assert_eq!(p.mode(ms(t + 1)), Mode::List(Item::Id));
}

#[test]
fn node_id_by_value_input() {
    let mut p = Panel::new(Params::FACTORY);
    open_menu(&mut p, 0);
    tap(&mut p, KEYMAP.confirm, 10);
    // The selected (rightmost) digit blinks.
    assert_eq!(p.view(ms(100)).screen.rows[1].cells_text(), "   125");
    assert_eq!(p.view(ms(600)).screen.rows[1].cells_text(), "   12 ");
    assert_eq!(p.next_change(ms(100)), Some(ms(500)));
    // 125 -> 106: the tens digit 2 counts up 8 times to 0; the units 5 once to 6.
    tap(&mut p, KEYMAP.value_input, 20);
    tap(&mut p, KEYMAP.digit_select, 30);
    for i in 0..8 {
        tap(&mut p, KEYMAP.value_input, 40 + i);
    }
    assert_eq!(rows(&p, 100), ["ID", "106"]);
    assert_eq!(p.view(ms(600)).screen.rows[1].cells_text(), "   1 6");
    assert_eq!(tap(&mut p, KEYMAP.confirm, 100), Some(Effect::SetNodeId(106)));
    assert_eq!(p.mode(ms(100)), Mode::List(Item::Id));
    // 0 and 128.. are not taken.
    tap(&mut p, KEYMAP.confirm, 200);
    tap(&mut p, KEYMAP.digit_select, 210);
    tap(&mut p, KEYMAP.digit_select, 220);
    for i in 0..9 {
        tap(&mut p, KEYMAP.value_input, 230 + i); // hundreds 1 -> 0
    }
    assert_eq!(rows(&p, 300), ["ID", "025"], "the node-ID of the parameters (125) was the start");
    tap(&mut p, KEYMAP.value_input, 300); // 125
    tap(&mut p, KEYMAP.value_input, 310); // 225
    assert_eq!(tap(&mut p, KEYMAP.confirm, 320), None);
    assert!(matches!(p.mode(ms(320)), Mode::EditId(_)), "stays for a correction");
    tap(&mut p, KEYMAP.back, 330);
    assert_eq!(p.mode(ms(330)), Mode::List(Item::Id));
}

#[test]
fn kbaud_from_its_list() {
    let mut p = Panel::new(Params { baud: 2, ..Params::FACTORY });
    open_menu(&mut p, 0);
    tap(&mut p, KEYMAP.value_input, 10);
    assert_eq!(rows(&p, 10), ["KBAUD", "250"]);
    tap(&mut p, KEYMAP.confirm, 20);
    let mut seen = Vec::new();
    for i in 0..5 {
        seen.push(rows(&p, 30 + i)[1].clone());
        tap(&mut p, KEYMAP.value_input, 30 + i);
    }
    assert_eq!(seen, ["250", "500", "800", "AUTO", "125"], "no 1000 in the list");
    tap(&mut p, KEYMAP.value_input, 40);
    assert_eq!(rows(&p, 40)[1], "500");
    assert_eq!(tap(&mut p, KEYMAP.confirm, 50), Some(Effect::SetBaud(3)));
    assert_eq!(p.mode(ms(50)), Mode::List(Item::Kbaud));
}

/// Opens CODE and enters `code` (six digits, left to right).
fn enter_code(p: &mut Panel, code: &str, t: u64) -> Option<Effect> {
    open_menu(p, t);
    tap(p, KEYMAP.value_input, t + 2);
    tap(p, KEYMAP.value_input, t + 3);
    assert_eq!(p.mode(ms(t + 3)), Mode::List(Item::Code));
    tap(p, KEYMAP.confirm, t + 4);
    assert_eq!(rows(p, t + 4), ["CODE", "000000"]);
    let digits: Vec<u8> = code.bytes().map(|b| b - b'0').collect();
    for (i, &d) in digits.iter().rev().enumerate() {
        if i > 0 {
            tap(p, KEYMAP.digit_select, t + 5);
        }
        for _ in 0..d {
            tap(p, KEYMAP.value_input, t + 5);
        }
    }
    assert_eq!(rows(p, t + 5), ["CODE", code]);
    tap(p, KEYMAP.confirm, t + 6)
}

#[test]
fn codes_restore_factory_settings() {
    for (code, scope) in
        [("011100", ResetScope::All), ("011102", ResetScope::AllExceptBus), ("011105", ResetScope::BusOnly)]
    {
        let mut p = Panel::new(Params::FACTORY);
        assert_eq!(enter_code(&mut p, code, 0), Some(Effect::FactoryReset(scope)), "{code}");
        assert_eq!(p.mode(ms(10)), Mode::Normal);
    }
    // An unknown code changes nothing and returns to the list.
    let mut p = Panel::new(Params::FACTORY);
    assert_eq!(enter_code(&mut p, "011101", 0), None);
    assert_eq!(p.mode(ms(10)), Mode::List(Item::Code));
}

#[test]
fn code_200000_shows_the_diagnosis() {
    let mut p = Panel::new(Params::FACTORY);
    p.set_diagnosis(&[DiagEntry { code: 0x8140, count: 2 }, DiagEntry { code: 0x8120, count: 5 }]);
    assert_eq!(enter_code(&mut p, "200000", 0), None);
    assert_eq!(p.mode(ms(10)), Mode::Diagnosis(0));
    assert_eq!(rows(&p, 10), ["1    2", "8140"]);
    assert_eq!(p.view(ms(10)).screen.rows[0].cells_text(), "1    2");
    tap(&mut p, KEYMAP.value_input, 20);
    assert_eq!(rows(&p, 20), ["2    5", "8120"]);
    tap(&mut p, KEYMAP.value_input, 30);
    assert_eq!(rows(&p, 30), ["1    2", "8140"]);
    tap(&mut p, KEYMAP.back, 40);
    assert_eq!(p.mode(ms(40)), Mode::List(Item::Code));
    // Empty list.
    let mut p = Panel::new(Params::FACTORY);
    enter_code(&mut p, "200000", 0);
    assert_eq!(rows(&p, 10), ["no Err", ""]);
}

#[test]
fn the_menu_closes_after_a_minute_without_keys() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D23);
    open_menu(&mut p, 0);
    tap(&mut p, KEYMAP.confirm, 1_000);
    assert_eq!(p.next_change(ms(1_000)), Some(ms(1_500)), "the selected digit blinks");
    assert!(matches!(p.mode(ms(1_000 + MENU_TIMEOUT_MS - 1)), Mode::EditId(_)));
    assert_eq!(p.mode(ms(1_000 + MENU_TIMEOUT_MS)), Mode::Normal);
    assert_eq!(rows(&p, 1_000 + MENU_TIMEOUT_MS), ["12345", "---"]);
    // In the list (nothing blinks) the time-out is the next change.
    let mut p = Panel::new(Params::FACTORY);
    open_menu(&mut p, 0);
    assert_eq!(p.next_change(ms(5)), Some(ms(1 + MENU_TIMEOUT_MS)));
}

#[test]
fn auto_id_shows_new_id_and_waits_for_its_key() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    assert!(!p.start_auto_id(0), "an illegal ID is refused");
    assert!(!p.start_auto_id(128));
    assert!(p.start_auto_id(0x12));
    assert_eq!(rows(&p, 0), ["New ID", ""]);
    assert_eq!(rows(&p, 3_600_000), ["New ID", ""], "no time-out of its own");
    // Other keys do nothing, not even acknowledge.
    for key in Key::ALL.into_iter().filter(|&k| k != KEYMAP.auto_id) {
        assert_eq!(tap(&mut p, key, 100), None, "{key:?}");
    }
    assert!(!p.set_points().get(Which::Sp1).acknowledged);
    assert_eq!(tap(&mut p, KEYMAP.auto_id, 200), Some(Effect::AutoIdAdopted(0x12)));
    assert_eq!(rows(&p, 200), ["12345", "---"]);
    // Ended from outside.
    assert!(p.start_auto_id(0x13));
    p.end_auto_id();
    assert_eq!(p.mode(ms(300)), Mode::Normal);
}

#[test]
fn power_up_display_test_and_led_sequence() {
    let mut p = Panel::new(Params::FACTORY);
    p.power_up(ms(0));
    assert_eq!(rows(&p, 0), ["8.8.8.8.8.8.", "8.8.8.8.8.8."]);
    let leds = |t| p.view(ms(t)).leds;
    assert_eq!(leds(0), Leds { left: GREEN, right: OFF });
    assert_eq!(leds(250), Leds { left: RED, right: OFF });
    assert_eq!(leds(500), Leds { left: OFF, right: GREEN });
    assert_eq!(leds(999), Leds { left: OFF, right: RED });
    assert_eq!(p.next_change(ms(0)), Some(ms(250)));
    assert_eq!(p.next_change(ms(800)), Some(ms(1000)));
    assert_eq!(rows(&p, 1000), ["---", "---"]);
    assert_eq!(leds(1000), Leds { left: OFF, right: OFF });
    // Keys do nothing during the test.
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    p.power_up(ms(0));
    assert_eq!(tap(&mut p, Key::Front, 10), None);
}

#[test]
fn backlight_flashing_through_the_panel() {
    let mut params = Params::FACTORY;
    params.lights.flash_backlight = true;
    params.lights.backlight_red = false;
    let p = Panel::new(params);
    assert_eq!(p.view(ms(100)).backlight, Backlight { white: true, red: false });
    assert_eq!(p.view(ms(600)).backlight, Backlight { white: false, red: false });
    assert_eq!(p.next_change(ms(600)), Some(ms(1000)));
}

/// Factory values of the panel's objects as `shared/spec/AP10T.od.csv` lists them.
const FACTORY_OBJECTS: [(u16, u8, u32); 19] = [
    (0x2003, 0, 1),
    (0x2004, 0, 1),
    (0x2005, 1, 1),
    (0x2005, 2, 5),
    (0x5F0A, 1, 0x7D),
    (0x5F0A, 3, 0),
    (0x5F0B, 0, 0),
    (0x5F11, 0, 0),
    (0x5F12, 1, 0),
    (0x5F12, 2, 1),
    (0x5F12, 3, 1),
    (0x5F12, 4, 1),
    (0x5F12, 5, 1),
    (0x5F12, 6, 0),
    (0x5F12, 7, 1),
    (0x5F12, 8, 1),
    (0x5F12, 9, 0),
    (0x5F1C, 0, 0),
    (0x5F1C, 1, 0),
];

#[test]
fn panel_parameters_by_object_with_factory_values_and_ranges() {
    use od_core::devices::ap10t::panel::{ParamError, PANEL_OBJECTS};
    let p = Params::FACTORY;
    for (i, &(index, sub, value)) in FACTORY_OBJECTS.iter().enumerate() {
        assert_eq!(PANEL_OBJECTS[i], (index, sub));
        assert_eq!(p.read(index, sub), Some(value), "{index:04X}.{sub}");
    }
    // Every object: its maximum is taken and read back, one above is refused.
    let max = |index: u16, sub: u8| match (index, sub) {
        (0x2005, 2) => 60,
        (0x5F0A, 1) => 0x7F,
        (0x5F0A, 3) => 5,
        (0x5F11, 0) => 4,
        (0x5F1C, 0) => 2,
        _ => 1,
    };
    for (index, sub) in PANEL_OBJECTS {
        let mut q = Params::FACTORY;
        let m = max(index, sub);
        assert_eq!(q.write(index, sub, m), Ok(()));
        assert_eq!(q.read(index, sub), Some(m));
        assert_eq!(q.write(index, sub, m + 1), Err(ParamError::OutOfRange), "{index:04X}.{sub}");
        assert_eq!(q.read(index, sub), Some(m), "unchanged after a refused write");
    }
    let mut q = Params::FACTORY;
    assert_eq!(q.write(0x2005, 2, 0), Err(ParamError::OutOfRange));
    assert_eq!(q.write(0x5F0A, 1, 0), Err(ParamError::OutOfRange));
    assert_eq!(q.write(0x5F19, 0, 0), Err(ParamError::NotAPanelParameter));
    assert_eq!(q.read(0x5F0A, 2), None, "Auto-ID is an event, not a panel parameter");
}

/// Index, sub-index and value of an expedited SDO frame (bytes 1-2, 3, 4-7).
fn sdo_object(frame: [u8; 8]) -> (u16, u8, u32) {
    (u16::from_le_bytes([frame[1], frame[2]]), frame[3], u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]))
}

#[test]
fn manual_sdo_examples_on_the_display() {
    // Manual 4.4.3 (digest E3b): 5F11h reads 2 (4F 11 5F 00 02 ..): two decimal places.
    let mut p = Panel::new(Params::FACTORY);
    let (index, sub, value) = sdo_object([0x4F, 0x11, 0x5F, 0x00, 0x02, 0x00, 0x00, 0x00]);
    p.params.write(index, sub, value).unwrap();
    p.receive(Which::Sp1, &D23);
    assert_eq!(rows(&p, 0)[0], "123.45");
    // Manual 4.4.3 (E4a): 2F 12 5F 01 01 00 00 00 turns the display by 180°.
    let (index, sub, value) = sdo_object([0x2F, 0x12, 0x5F, 0x01, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!((index, sub, value), (0x5F12, 1, 1));
    p.params.write(index, sub, value).unwrap();
    let v = p.view(ms(0));
    assert!(v.screen.rotated);
    assert_eq!(v.screen.physical()[1].map(|c| c.ch), *b"54321 ");
    // The point after "3" (logical cell 3) is lit on physical digit 1.
    assert_eq!(v.screen.physical()[1].map(|c| c.dp), [false, true, false, false, false, false]);
}

mod properties {
    use super::*;
    use od_core::devices::ap10t::screen::{set_point_row, RowStyle};
    use od_core::devices::ap10t::SetPoint;
    use proptest::prelude::*;

    fn key() -> impl Strategy<Value = Key> {
        prop_oneof![Just(Key::Front), Just(Key::Left), Just(Key::Star), Just(Key::Up)]
    }

    /// One input to the panel.
    #[derive(Clone, Debug)]
    enum Input {
        Rpdo(bool, [u8; 8]),
        Tap(Key),
        Wait(u64),
        AutoId(u8),
    }

    fn input() -> impl Strategy<Value = Input> {
        prop_oneof![
            (any::<bool>(), any::<[u8; 8]>()).prop_map(|(w, d)| Input::Rpdo(w, d)),
            key().prop_map(Input::Tap),
            (0u64..70_000).prop_map(Input::Wait),
            any::<u8>().prop_map(Input::AutoId),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

        /// A number in the standard range reads back as itself; nothing panics and no row is
        /// longer than six cells anywhere in the i32 range.
        #[test]
        fn numbers_read_back(v in any::<i32>(), decimals in 0u8..=4, extended: bool, ack: bool, t in 0u64..5_000) {
            let b = v.to_le_bytes();
            let sp = SetPoint { bytes: [b[0], b[1], b[2], b[3], 0, 0], ascii: false, valid: true, acknowledged: ack };
            let style = RowStyle { decimals, extended, steady_unacknowledged: true };
            let row = set_point_row(&sp, style, ms(t));
            let text = row.text();
            prop_assert!(text.chars().filter(|&c| c != '.').count() <= 6);
            if (-19_999..=99_999).contains(&v) {
                let digits: String = text.chars().filter(|&c| c != '.').collect();
                prop_assert_eq!(digits.parse::<i32>().unwrap(), v);
                prop_assert_eq!(text.contains('.'), decimals > 0);
            } else if !(extended && ack && (-999_999..=-20_000).contains(&v)) {
                prop_assert_eq!(text.as_str(), "FULLL");
            }
        }

        /// The view stays as it is until `next_change` (the shell may sleep until then), and
        /// the status word's acknowledgement bits never claim an invalid set point.
        #[test]
        fn view_is_constant_until_next_change(inputs in proptest::collection::vec(input(), 1..40), params_bits: u32) {
            let mut params = Params::FACTORY;
            for (i, (index, sub)) in od_core::devices::ap10t::panel::PANEL_OBJECTS.iter().enumerate() {
                if *index == 0x5F12 || *index == 0x5F0B || *index == 0x5F1C && *sub == 1 {
                    let _ = params.write(*index, *sub, params_bits >> i & 1);
                }
            }
            let _ = params.write(0x5F11, 0, params_bits >> 24 & 7);
            let _ = params.write(0x5F1C, 0, params_bits >> 28 & 3);
            let mut p = Panel::new(params);
            p.power_up(ms(0));
            let mut now = 0u64;
            for inp in inputs {
                match inp {
                    Input::Rpdo(w, d) => p.receive(if w { Which::Sp1 } else { Which::Sp2 }, &d),
                    Input::Tap(k) => { tap(&mut p, k, now); }
                    Input::Wait(dt) => now += dt,
                    Input::AutoId(id) => { p.start_auto_id(id); }
                }
                let sw = p.status_word();
                prop_assert!(!sw.sp1_ack || sw.sp1_valid);
                prop_assert!(!sw.sp2_ack || sw.sp2_valid);
                let view = p.view(ms(now));
                let until = p.next_change(ms(now)).map(|i| i.as_millis()).unwrap_or(now + 3_000);
                prop_assert!(until > now);
                for t in [now + 1, (now + until) / 2, until - 1] {
                    if t > now && t < until {
                        prop_assert_eq!(p.view(ms(t)), view, "at {} (now {}, next {})", t, now, until);
                    }
                }
            }
        }
    }
}

#[test]
fn view_as_one_line() {
    let mut p = Panel::new(Params::FACTORY);
    p.receive(Which::Sp1, &D20);
    assert_eq!(p.view(ms(0)).to_string(), "[ 12345|   ---] LED red/off light white+red");
    assert_eq!(p.view(ms(500)).to_string(), "[      |   ---] LED red/off light white+red");
    p.params.write(0x5F12, 1, 1).unwrap();
    p.params.write(0x5F12, 8, 0).unwrap();
    p.params.write(0x5F11, 0, 1).unwrap();
    tap(&mut p, Key::Front, 0);
    assert_eq!(p.view(ms(0)).to_string(), "[ 1234.5|   ---] LED green/off light white rotated");
}
