//! SGH10 LSS slave on the bus (manual §4.6, digest 3.10 and 6.2, CiA 305): the master sends X,
//! the node answers Y at time T, byte for byte. Beyond the manual: identify remote slave,
//! identify non-configured remote slave and Fastscan as python-canopen's `LssMaster` uses them.
//! Decisions in docs/decisions.md, "LSS".
//!
//! The serial number (1018h.04) is factory data: a test sets it through `Node::split()` before
//! the node joins the bus, as the firmware's factory flash would.

use od_core::devices::sgh10;
use od_core::lss::LssState;
use od_core::node::{CanopenDevice, Device, Output};
use od_core::od::{Entry, GroupMask};
use od_core::storage::{identity, ParamFlash, Region};
use od_core::{Bitrate, Frame, NmtState, Node};
use proptest::prelude::*;
use tests_host::bus::{Bus, Sender};
use tests_host::flash::RamFlash;
use tests_host::TableOnly;

const SERIAL: u32 = 0x0012_D687;

/// An SGH10 with `node_id` (255: none) and serial number `serial`, powered on at 500 kbit/s.
fn sgh10(node_id: u8, serial: u32) -> Node<TableOnly> {
    let mut node = Node::new(TableOnly(sgh10::TABLE), node_id, Bitrate::K500);
    assert!(node.split().1.od.set_value(0x1018, 4, serial));
    node
}

/// A bus with one SGH10 (node-ID 1, serial [`SERIAL`]) that has sent its boot-up.
fn bus_with_sgh10() -> Bus {
    let mut bus = Bus::new();
    bus.add(sgh10(1, SERIAL));
    bus.expect(0x701, &[0x00]);
    bus
}

/// The master sends an LSS request.
fn lss(bus: &mut Bus, data: [u8; 8]) {
    bus.send(Frame::std(0x7E5, &data));
}

/// The master sends an LSS request and expects exactly this answer.
#[track_caller]
fn lss_answer(bus: &mut Bus, data: [u8; 8], answer: [u8; 8]) {
    lss(bus, data);
    bus.expect(0x7E4, &answer);
    bus.expect_silence();
}

/// The master sends an LSS request and expects no answer.
#[track_caller]
fn lss_silent(bus: &mut Bus, data: [u8; 8]) {
    lss(bus, data);
    bus.expect_silence();
}

fn nmt(bus: &mut Bus, cs: u8, node: u8) {
    bus.send(Frame::std(0x000, &[cs, node]));
}

/// Switch state selective with the SGH10's LSS address and `serial`.
fn select(bus: &mut Bus, serial: u32) {
    let s = serial.to_le_bytes();
    lss_silent(bus, [0x40, 0x95, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_silent(bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss_silent(bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss(bus, [0x43, s[0], s[1], s[2], s[3], 0x00, 0x00, 0x00]);
}

/// 5F0Ah.01 and .02 of node `n`: the pending node-ID and bit-rate code.
fn pending(bus: &mut Bus, n: usize) -> (u32, u32) {
    let od = &bus.station(n).core().od;
    (od.value(0x5F0A, 1).unwrap(), od.value(0x5F0A, 2).unwrap())
}

fn lss_state(bus: &mut Bus, n: usize) -> LssState {
    bus.station(n).lss().unwrap().state()
}

#[test]
fn switch_state_global_opens_the_inquire_services() {
    let mut bus = bus_with_sgh10();
    let s = SERIAL.to_le_bytes();
    // Digest 6.2: switch state global → configuration, no answer.
    lss_silent(&mut bus, [0x04, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(lss_state(&mut bus, 0), LssState::Configuration);
    lss_answer(&mut bus, [0x5A, 0, 0, 0, 0, 0, 0, 0], [0x5A, 0x95, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5B, 0, 0, 0, 0, 0, 0, 0], [0x5B, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    // SGH10 A8: the revision in bytes 1..4 (printed layout would force byte 4 = 00h).
    lss_answer(&mut bus, [0x5C, 0, 0, 0, 0, 0, 0, 0], [0x5C, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5D, 0, 0, 0, 0, 0, 0, 0], [0x5D, s[0], s[1], s[2], s[3], 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // Back to waiting: the inquire services are not available there (Table 10).
    lss_silent(&mut bus, [0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(lss_state(&mut bus, 0), LssState::Waiting);
    for cs in 0x5A..=0x5E {
        lss_silent(&mut bus, [cs, 0, 0, 0, 0, 0, 0, 0]);
    }
}

#[test]
fn digest_6_2_sequence_selective_configure_store_inquire_activate() {
    let mut bus = bus_with_sgh10();
    let s = SERIAL.to_le_bytes();
    select(&mut bus, SERIAL);
    bus.expect(0x7E4, &[0x44, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect_silence();
    lss_answer(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x11, 0x80, 0, 0, 0, 0, 0, 0], [0x11, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x13, 0x00, 0x03, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x13, 0x00, 0x08, 0, 0, 0, 0, 0], [0x13, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // Pending: node-ID 5, 250 kbit/s = 5F0Ah.02 code 4; the refused requests changed nothing.
    assert_eq!(pending(&mut bus, 0), (5, 4));
    lss_answer(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0], [0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5A, 0, 0, 0, 0, 0, 0, 0], [0x5A, 0x95, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5B, 0, 0, 0, 0, 0, 0, 0], [0x5B, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5C, 0, 0, 0, 0, 0, 0, 0], [0x5C, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x5D, 0, 0, 0, 0, 0, 0, 0], [0x5D, s[0], s[1], s[2], s[3], 0x00, 0x00, 0x00]);
    // The active node-ID, not the pending one.
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);

    // Activate bit timing, switch delay 1000 ms, then back to LSS waiting (SGH10 A20).
    let t0 = bus.now();
    lss_silent(&mut bus, [0x15, 0xE8, 0x03, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::Initialising);
    bus.advance(999);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    bus.advance(1);
    assert_eq!(bus.node_bitrate(0), Bitrate::K250, "new rate after d1");
    bus.set_bitrate(Bitrate::K250);
    bus.advance(999);
    bus.expect_silence();
    bus.advance(1);
    let boot = bus.expect(0x701, &[0x00]);
    assert_eq!(boot.at, t0.add_millis(2000), "boot-up on the new rate after d2");
    assert_eq!(lss_state(&mut bus, 0), LssState::Waiting);
    // NMT reset communication activates the configured node-ID.
    nmt(&mut bus, 0x82, 0x01);
    bus.expect(0x705, &[0x00]);
    bus.expect_silence();
    assert_eq!(bus.station(0).core().node_id, 5);
}

#[test]
fn configure_node_id_then_waiting_and_reset_communication_boots_on_705() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_silent(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    // A configured node keeps its active node-ID until NMT resets it (manual §4.6.2.1).
    nmt(&mut bus, 0x01, 0x01);
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::Operational);
    nmt(&mut bus, 0x82, 0x01);
    bus.expect(0x705, &[0x00]);
    bus.expect_silence();
    // The node now answers on node-ID 5 only; the bit rate did not change.
    nmt(&mut bus, 0x82, 0x01);
    bus.expect_silence();
    nmt(&mut bus, 0x81, 0x05);
    bus.expect(0x705, &[0x00]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
}

#[test]
fn nmt_reset_in_lss_configuration_activates_and_returns_to_waiting() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x07, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    nmt(&mut bus, 0x82, 0x00);
    bus.expect(0x707, &[0x00]);
    // After the reset the slave starts again in LSS waiting.
    assert_eq!(lss_state(&mut bus, 0), LssState::Waiting);
    lss_silent(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn configure_node_id_accepts_1_to_127_and_ff_only() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    for nid in 0..=255u8 {
        let before = pending(&mut bus, 0).0;
        lss(&mut bus, [0x11, nid, 0, 0, 0, 0, 0, 0]);
        let ok = (1..=127).contains(&nid) || nid == 0xFF;
        bus.expect(0x7E4, &[0x11, if ok { 0x00 } else { 0x01 }, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
        bus.expect_silence();
        assert_eq!(pending(&mut bus, 0).0, if ok { nid as u32 } else { before }, "NID {nid:02X}");
    }
}

#[test]
fn configure_bit_timing_takes_the_manual_table_and_nothing_else() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    // Table index -> 5F0Ah.02 code (digest 3.10: TI 0↔7, 1↔6, 2↔5, 3↔4, 4↔3, 6↔2, 7↔1).
    let table = [(0u8, 7u32), (1, 6), (2, 5), (3, 4), (4, 3), (6, 2), (7, 1)];
    for index in 0..=255u8 {
        let before = pending(&mut bus, 0).1;
        lss(&mut bus, [0x13, 0x00, index, 0, 0, 0, 0, 0]);
        match table.iter().find(|(i, _)| *i == index) {
            Some(&(_, code)) => {
                bus.expect(0x7E4, &[0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
                assert_eq!(pending(&mut bus, 0).1, code, "index {index}");
            }
            None => {
                // 5 "reserved", 8 and 9 "not supported", the rest beyond the table.
                bus.expect(0x7E4, &[0x13, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
                assert_eq!(pending(&mut bus, 0).1, before, "index {index}");
            }
        }
        bus.expect_silence();
    }
    // Only table selector 00h: 01h, manufacturer tables 80h..FEh and FFh are refused.
    for selector in [0x01, 0x7F, 0x80, 0xFE, 0xFF] {
        lss_answer(&mut bus, [0x13, selector, 0x02, 0, 0, 0, 0, 0], [0x13, 0x01, 0, 0, 0, 0, 0, 0]);
    }
}

#[test]
fn activate_bit_timing_is_silent_until_the_boot_up_on_the_new_rate() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x13, 0x00, 0x00, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // 250 ms: d1 = d2 = 250 ms.
    lss_silent(&mut bus, [0x15, 0xFA, 0x00, 0, 0, 0, 0, 0]);
    let mark = bus.log.len();
    // Requests meanwhile get no answer, NMT is not heard.
    lss_silent(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0]);
    nmt(&mut bus, 0x82, 0x01);
    bus.expect_silence();
    bus.advance(249);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    bus.advance(1);
    assert_eq!(bus.node_bitrate(0), Bitrate::K1000);
    // The master stays at 500 kbit/s: it hears nothing at all, the boot-up (at 1 Mbit/s)
    // included; nothing went out at the old rate either.
    bus.advance(1000);
    bus.expect_silence();
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::PreOperational);
    assert!(!bus.log[mark..].iter().any(|s| s.from == Sender::Node(0)));
    // At the new rate the node answers again, still in LSS configuration (the master did not
    // switch it to waiting): activate bit timing does not change the LSS state (CiA 305).
    bus.set_bitrate(Bitrate::K1000);
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x01, 0, 0, 0, 0, 0, 0]);
    nmt(&mut bus, 0x82, 0x01);
    bus.expect(0x701, &[0x00]);
}

#[test]
fn no_service_sends_during_the_switch_delays() {
    // A producer heartbeat of 100 ms would otherwise run through the delays.
    let mut node = sgh10(1, SERIAL);
    assert!(node.split().1.od.set_value(0x1017, 0, 100));
    let mut bus = Bus::new();
    bus.add(node);
    bus.advance(1000);
    bus.drain();
    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x13, 0x00, 0x01, 0, 0, 0, 0, 0]);
    let t0 = bus.now();
    lss(&mut bus, [0x15, 0xFA, 0x00, 0, 0, 0, 0, 0]);
    let mark = bus.log.len();
    bus.advance(250);
    bus.set_bitrate(Bitrate::K800);
    bus.advance(250);
    let sent: Vec<_> = bus.log[mark..].iter().filter(|s| s.from == Sender::Node(0)).collect();
    assert_eq!(sent.first().map(|s| (s.at, s.frame)), Some((t0.add_millis(500), Frame::std(0x701, &[0x00]))));
    assert!(sent.len() == 1, "sent during the switch or with the boot-up: {sent:?}");
}

#[test]
fn activate_bit_timing_with_zero_delay_switches_at_once() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x13, 0x00, 0x07, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss(&mut bus, [0x15, 0x00, 0x00, 0, 0, 0, 0, 0]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K20);
    // The boot-up went out at once, at 20 kbit/s: the master at 500 kbit/s did not see it.
    bus.expect_silence();
    let boot = bus.log.last().unwrap();
    assert_eq!((boot.at, boot.frame.id), (od_core::Instant::ZERO, od_core::CanId::Std(0x7E5)));
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::PreOperational);
}

#[test]
fn activate_bit_timing_is_ignored_in_lss_waiting() {
    let mut bus = bus_with_sgh10();
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_silent(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x15, 0x0A, 0x00, 0, 0, 0, 0, 0]);
    bus.advance(100);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    // The node is still on the bus: NMT reaches it, and the reset leaves an LSS-configured
    // rate pending (CiA 305: activate bit timing or a power cycle applies it; D-LSS-15).
    nmt(&mut bus, 0x82, 0x01);
    bus.expect(0x701, &[0x00]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    // Activate bit timing in configuration state applies it.
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x15, 0x0A, 0x00, 0, 0, 0, 0, 0]);
    bus.advance(10);
    assert_eq!(bus.node_bitrate(0), Bitrate::K125);
}

#[test]
fn store_configuration_answers_when_the_flash_is_written() {
    let region = Region { offset: 0, pages: 2 };
    let params = ParamFlash::new(RamFlash::new(2), region, identity(sgh10::TABLE));
    let mut bus = Bus::new();
    bus.add_with_flash(params, |loaded| {
        let mut node = Node::boot(TableOnly(sgh10::TABLE), loaded);
        node.split().1.od.set_value(0x1018, 4, SERIAL);
        node
    });
    bus.expect(0x701, &[0x00]);
    select(&mut bus, SERIAL);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x13, 0x00, 0x03, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    // A worn-out flash: error 02h "error occurred during storing", nothing persisted.
    bus.fail_stores(0, true);
    lss_answer(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0], [0x17, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    // Again, on a good flash: 17 00, and the next power-on uses node-ID 5 at 250 kbit/s
    // (manual: "execute power off/on after Store configuration").
    bus.fail_stores(0, false);
    select(&mut bus, SERIAL);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x13, 0x00, 0x03, 0, 0, 0, 0, 0], [0x13, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0], [0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_silent(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.power_cycle(0);
    bus.expect_silence();
    assert_eq!(bus.node_bitrate(0), Bitrate::K250);
    bus.set_bitrate(Bitrate::K250);
    bus.power_cycle(0);
    bus.expect(0x705, &[0x00]);
    // Only the LSS group was stored: the other parameters stay at their defaults.
    assert_eq!(bus.station(0).core().od.value(0x6002, 0), Some(10239));
}

#[test]
fn stored_unconfigured_node_id_powers_on_silent() {
    let region = Region { offset: 0, pages: 2 };
    let params = ParamFlash::new(RamFlash::new(2), region, identity(sgh10::TABLE));
    let mut bus = Bus::new();
    bus.add_with_flash(params, |loaded| Node::boot(TableOnly(sgh10::TABLE), loaded));
    bus.expect(0x701, &[0x00]);
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0xFF, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss_answer(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0], [0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.power_cycle(0);
    bus.advance(1000);
    bus.expect_silence();
    nmt(&mut bus, 0x82, 0x00);
    bus.expect_silence();
    // LSS only: the inquired node-ID is FFh.
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0xFF, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn services_in_the_wrong_lss_state_are_ignored() {
    let mut bus = bus_with_sgh10();
    // LSS waiting: configuration and inquire services get nothing and change nothing.
    for data in [
        [0x11, 0x05, 0, 0, 0, 0, 0, 0],
        [0x13, 0x00, 0x03, 0, 0, 0, 0, 0],
        [0x15, 0x0A, 0x00, 0, 0, 0, 0, 0],
        [0x17, 0, 0, 0, 0, 0, 0, 0],
        [0x5A, 0, 0, 0, 0, 0, 0, 0],
        [0x5B, 0, 0, 0, 0, 0, 0, 0],
        [0x5C, 0, 0, 0, 0, 0, 0, 0],
        [0x5D, 0, 0, 0, 0, 0, 0, 0],
        [0x5E, 0, 0, 0, 0, 0, 0, 0],
    ] {
        lss_silent(&mut bus, data);
    }
    assert_eq!(pending(&mut bus, 0), (1, 5));
    assert!(!bus.station(0).lss().unwrap().switching());
    // LSS configuration: switch state selective is not available (Table 10), nor is Fastscan.
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    select(&mut bus, SERIAL);
    bus.expect_silence();
    lss_silent(&mut bus, [0x51, 0, 0, 0, 0, 0x80, 0, 0]);
    // Malformed frames and unknown command specifiers: no answer, in either state.
    bus.send(Frame::std(0x7E5, &[0x5E]));
    bus.send(Frame::std(0x7E5, &[0x5E, 0, 0, 0, 0, 0, 0]));
    bus.send(Frame::remote(od_core::CanId::Std(0x7E5), 8));
    for cs in [0x00, 0x05, 0x12, 0x44, 0x4F, 0x50, 0x52, 0x5F, 0xFF] {
        lss(&mut bus, [cs, 0, 0, 0, 0, 0, 0, 0]);
    }
    lss(&mut bus, [0x04, 0x02, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
    assert_eq!(lss_state(&mut bus, 0), LssState::Configuration);
    // Still answering what the state allows.
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x01, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn lss_works_in_stopped() {
    // SGH10 A23: "Only NMT communication is enabled" in STOPPED; LSS is independent of NMT.
    let mut bus = bus_with_sgh10();
    nmt(&mut bus, 0x02, 0x01);
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::Stopped);
    lss_silent(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x01, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn switch_state_selective_needs_all_four_parts_in_order() {
    let mut bus = Bus::new();
    bus.add(sgh10(1, 100));
    bus.add(sgh10(2, 200));
    bus.drain();
    // Wrong serial, wrong vendor, parts out of order or interrupted: nobody is selected.
    select(&mut bus, 300);
    bus.expect_silence();
    lss_silent(&mut bus, [0x40, 0x96, 0x01, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss_silent(&mut bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss_silent(&mut bus, [0x43, 200, 0, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x40, 0x95, 0x01, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss_silent(&mut bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss_silent(&mut bus, [0x43, 200, 0, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x40, 0x95, 0x01, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss_silent(&mut bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFE, 0, 0, 0]);
    lss_silent(&mut bus, [0x43, 200, 0, 0, 0, 0, 0, 0]);
    assert_eq!((lss_state(&mut bus, 0), lss_state(&mut bus, 1)), (LssState::Waiting, LssState::Waiting));
    // The right address selects exactly one node: only it answers the inquiries.
    select(&mut bus, 200);
    let ack = bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(ack.from, Sender::Node(1));
    bus.expect_silence();
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0x02, 0, 0, 0, 0, 0, 0]);
}

/// Identify remote slave with these bounds; returns who answered 4Fh.
fn identify(bus: &mut Bus, vendor: u32, product: u32, rev: (u32, u32), serial: (u32, u32)) -> Vec<Sender> {
    for (cs, v) in [(0x46, vendor), (0x47, product), (0x48, rev.0), (0x49, rev.1), (0x4A, serial.0), (0x4B, serial.1)] {
        let b = v.to_le_bytes();
        lss(bus, [cs, b[0], b[1], b[2], b[3], 0, 0, 0]);
    }
    bus.drain()
        .into_iter()
        .map(|s| {
            assert_eq!(s.frame, Frame::std(0x7E4, &[0x4F, 0, 0, 0, 0, 0, 0, 0]));
            s.from
        })
        .collect()
}

#[test]
fn identify_remote_slave_answers_within_the_ranges() {
    let mut bus = Bus::new();
    bus.add(sgh10(1, 100));
    bus.add(sgh10(2, 200));
    bus.drain();
    let any = (0, u32::MAX);
    let (n0, n1) = (Sender::Node(0), Sender::Node(1));
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, any), vec![n0, n1]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, (100, 100)), vec![n0]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, (101, 200)), vec![n1]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, (0, 99)), vec![]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, (201, u32::MAX)), vec![]);
    // The revision number FFFFFFFFh must lie within the revision bounds.
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, (u32::MAX, u32::MAX), any), vec![n0, n1]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, (0, u32::MAX - 1), any), vec![]);
    // Vendor and product must be equal.
    assert_eq!(identify(&mut bus, 0x196, u32::MAX, any, any), vec![]);
    assert_eq!(identify(&mut bus, 0x195, 0, any, any), vec![]);
    // Also in LSS configuration, and it changes no state.
    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(identify(&mut bus, 0x195, u32::MAX, any, (150, 250)), vec![n1]);
    assert_eq!((lss_state(&mut bus, 0), lss_state(&mut bus, 1)), (LssState::Configuration, LssState::Configuration));
    // A step out of order starts over: no answer.
    lss(&mut bus, [0x46, 0x95, 0x01, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x47, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    lss(&mut bus, [0x4A, 0, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x4B, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    bus.expect_silence();
}

#[test]
fn identify_non_configured_remote_slave_answers_only_without_node_id() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, 100));
    bus.add(sgh10(3, 200));
    bus.expect(0x703, &[0x00]);
    bus.expect_silence();
    lss(&mut bus, [0x4C, 0, 0, 0, 0, 0, 0, 0]);
    let answer = bus.expect(0x7E4, &[0x50, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(answer.from, Sender::Node(0));
    bus.expect_silence();
    // Once it has a pending node-ID it is no longer "non-configured".
    select(&mut bus, 100);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x0A, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x4C, 0, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn unconfigured_node_is_silent_until_lss_gives_it_a_node_id() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, SERIAL));
    bus.advance(1000);
    bus.expect_silence();
    // NMT cannot reach it.
    nmt(&mut bus, 0x82, 0x00);
    nmt(&mut bus, 0x81, 0x00);
    bus.expect_silence();
    select(&mut bus, SERIAL);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x5E, 0xFF, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x0A, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0, 0, 0, 0, 0, 0]);
    // CiA 305: switched back to waiting, a node without a node-ID activates the new one itself.
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x70A, &[0x00]);
    bus.expect_silence();
    nmt(&mut bus, 0x01, 0x0A);
    assert_eq!(bus.station(0).nmt().unwrap(), NmtState::Operational);
}

#[test]
fn unconfigured_node_gets_node_id_and_bit_rate_in_one_session() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, SERIAL));
    select(&mut bus, SERIAL);
    bus.expect(0x7E4, &[0x44, 0, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x11, 0x0B, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0, 0, 0, 0, 0, 0]);
    lss_answer(&mut bus, [0x13, 0x00, 0x01, 0, 0, 0, 0, 0], [0x13, 0x00, 0, 0, 0, 0, 0, 0]);
    let t0 = bus.now();
    lss_silent(&mut bus, [0x15, 0x14, 0x00, 0, 0, 0, 0, 0]);
    lss_silent(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.set_bitrate(Bitrate::K800);
    bus.advance(100);
    let boot = bus.expect(0x70B, &[0x00]);
    assert_eq!(boot.at, t0.add_millis(40));
    bus.expect_silence();
}

/// One Fastscan request as python-canopen's `LssMaster.fast_scan()` sends it (51h, IDNumber
/// LSB first, BitChecked, LSSSub, LSSNext); true if any slave answered 4Fh.
fn fastscan_request(bus: &mut Bus, id: u32, bit_checked: u8, sub: u8, next: u8) -> bool {
    let b = id.to_le_bytes();
    lss(bus, [0x51, b[0], b[1], b[2], b[3], bit_checked, sub, next]);
    let answers = bus.drain();
    for a in &answers {
        assert_eq!(a.frame, Frame::std(0x7E4, &[0x4F, 0, 0, 0, 0, 0, 0, 0]));
    }
    !answers.is_empty()
}

/// A Fastscan master: python-canopen's algorithm re-implemented. Returns the LSS address of the
/// non-configured slave it found (now in LSS configuration), or `None`.
fn fast_scan(bus: &mut Bus) -> Option<[u32; 4]> {
    let mut id = [0u32; 4];
    if !fastscan_request(bus, 0, 0x80, 0, 0) {
        return None;
    }
    let mut next = 0;
    for sub in 0..4u8 {
        for bit in (0..32u8).rev() {
            if !fastscan_request(bus, id[sub as usize], bit, sub, next) {
                id[sub as usize] |= 1 << bit;
            }
        }
        next = (sub + 1) & 3;
        if !fastscan_request(bus, id[sub as usize], 0, sub, next) {
            return None;
        }
    }
    Some(id)
}

/// Finds, configures and activates every non-configured node, giving node-IDs from 10 up;
/// returns the serial numbers in the order found.
fn commission_all(bus: &mut Bus) -> Vec<u32> {
    let mut found = Vec::new();
    while let Some(address) = fast_scan(bus) {
        assert_eq!(address[..3], [0x195, u32::MAX, u32::MAX]);
        let serial = address[3];
        // Exactly the found node is in LSS configuration.
        let s = serial.to_le_bytes();
        lss_answer(bus, [0x5D, 0, 0, 0, 0, 0, 0, 0], [0x5D, s[0], s[1], s[2], s[3], 0, 0, 0]);
        let nid = 10 + found.len() as u8;
        lss_answer(bus, [0x11, nid, 0, 0, 0, 0, 0, 0], [0x11, 0x00, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x700 + nid as u16, &[0x00]);
        bus.expect_silence();
        found.push(serial);
        assert!(found.len() <= 8, "Fastscan does not end");
    }
    found
}

#[test]
fn fastscan_finds_one_unconfigured_node() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, 0x8A3F_1C05));
    assert_eq!(fast_scan(&mut bus), Some([0x195, u32::MAX, u32::MAX, 0x8A3F_1C05]));
    assert_eq!(lss_state(&mut bus, 0), LssState::Configuration);
}

#[test]
fn fastscan_finds_each_of_two_unconfigured_nodes() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, 0x8A3F_1C44));
    bus.add(sgh10(0xFF, 0x8A3F_1C05));
    // A configured node on the same bus takes no part.
    bus.add(sgh10(1, 0x0000_0001));
    bus.expect(0x701, &[0x00]);
    assert_eq!(commission_all(&mut bus), vec![0x8A3F_1C05, 0x8A3F_1C44]);
    assert_eq!(bus.station(1).core().node_id, 10);
    assert_eq!(bus.station(0).core().node_id, 11);
    assert_eq!(bus.station(2).core().node_id, 1);
}

#[test]
fn fastscan_needs_the_reset_and_lss_pos() {
    let mut bus = Bus::new();
    bus.add(sgh10(0xFF, 7));
    // Before any reset LSSPos is vendor: a request for another part is not answered.
    assert!(!fastscan_request(&mut bus, 0, 31, 3, 3));
    assert!(fastscan_request(&mut bus, 0, 0x80, 0, 0));
    // Vendor 00000195h: bits 31..9 are 0, so "bits 31..9 = 0" matches, "31..8 = 0" does not.
    assert!(fastscan_request(&mut bus, 0, 9, 0, 0));
    assert!(!fastscan_request(&mut bus, 0, 8, 0, 0));
    assert!(fastscan_request(&mut bus, 0x195, 0, 0, 1));
    // LSSPos is now product: a vendor request is not answered.
    assert!(!fastscan_request(&mut bus, 0x195, 0, 0, 1));
    assert!(fastscan_request(&mut bus, u32::MAX, 0, 1, 2));
    assert!(fastscan_request(&mut bus, u32::MAX, 0, 2, 3));
    assert_eq!(lss_state(&mut bus, 0), LssState::Waiting);
    assert!(fastscan_request(&mut bus, 7, 0, 3, 0));
    assert_eq!(lss_state(&mut bus, 0), LssState::Configuration);
}

/// A device with the SGH10 dictionary and no LSS slave (as the AP10T and WV58MR declare).
struct NoLss;

impl Device for NoLss {
    fn table(&self) -> &'static [Entry] {
        sgh10::TABLE
    }
}

impl CanopenDevice for NoLss {
    fn has_lss(&self) -> bool {
        false
    }
}

#[test]
fn a_device_without_lss_ignores_7e5() {
    let mut bus = Bus::new();
    let mut node = Node::new(NoLss, 0xFF, Bitrate::K500);
    node.split().1.od.set_value(0x1018, 4, 9);
    bus.add(node);
    bus.add(Node::new(NoLss, 4, Bitrate::K500));
    bus.expect(0x704, &[0x00]);
    for data in [[0x04, 0x01, 0, 0, 0, 0, 0, 0], [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x4C, 0, 0, 0, 0, 0, 0, 0]] {
        lss_silent(&mut bus, data);
    }
    assert_eq!(fast_scan(&mut bus), None);
    assert!(!bus.station(0).lss().unwrap().enabled());
}

#[test]
fn declared_bit_rate_codes_cover_the_pending_entry_limits() {
    // Every 5F0Ah.02 value an SDO client may write names a rate the node can switch to.
    let e = sgh10::TABLE.iter().find(|e| (e.index, e.sub) == (0x5F0A, 2)).unwrap();
    let (lo, hi) = e.limits().unwrap();
    let codes = TableOnly(sgh10::TABLE).bitrate_codes();
    for v in lo..=hi {
        assert!(codes.iter().any(|(c, _)| *c as i64 == v), "code {v}");
    }
    assert_eq!(codes.len() as i64, hi - lo + 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Fastscan finds every non-configured node, whatever their serial numbers, lowest LSS
    /// address first, and never a configured one.
    #[test]
    fn fastscan_finds_every_unconfigured_node_in_address_order(
        serials in proptest::collection::btree_set(any::<u32>(), 1..4),
        configured in any::<u32>(),
    ) {
        let mut bus = Bus::new();
        let serials: Vec<u32> = serials.into_iter().collect();
        // Added in descending order, so the bus order is not the answer.
        for &s in serials.iter().rev() {
            bus.add(sgh10(0xFF, s));
        }
        bus.add(sgh10(1, configured));
        bus.drain();
        prop_assert_eq!(commission_all(&mut bus), serials);
    }
}

#[test]
fn store_configuration_waits_for_the_shell_and_blocks_activate_meanwhile() {
    // Without a bus: the shell takes its time with the flash.
    let mut node = sgh10(1, SERIAL);
    let t = od_core::Instant::ZERO;
    node.poll(t);
    let req = |data: [u8; 8]| Frame::std(0x7E5, &data);
    node.on_frame(&req([0x04, 0x01, 0, 0, 0, 0, 0, 0]), t);
    while node.next_output().is_some() {}
    node.on_frame(&req([0x17, 0, 0, 0, 0, 0, 0, 0]), t);
    assert_eq!(node.next_output(), Some(Output::Store(GroupMask::LSS)));
    assert_eq!(node.next_output(), None);
    // A repeated request and an activate bit timing wait: nothing happens.
    node.on_frame(&req([0x17, 0, 0, 0, 0, 0, 0, 0]), t);
    node.on_frame(&req([0x15, 0x01, 0x00, 0, 0, 0, 0, 0]), t);
    assert_eq!(node.next_output(), None);
    assert!(!node.lss().switching());
    // The shell reports: one answer.
    node.store_done(Ok(()), t);
    assert_eq!(node.next_output(), Some(Output::Frame(Frame::std(0x7E4, &[0x17, 0, 0, 0, 0, 0, 0, 0]))));
    assert_eq!(node.next_output(), None);
    node.on_frame(&req([0x15, 0x01, 0x00, 0, 0, 0, 0, 0]), t);
    assert!(node.lss().switching());
}
