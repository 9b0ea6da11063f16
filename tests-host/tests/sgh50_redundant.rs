//! The SGH50 redundant version on one bus: two encoders, each a full node of the same
//! firmware, node-IDs 1 and 2 ex works, different serial numbers (SGH50 digest §1.1, 6.2, 6.5;
//! decision D-SGH50-4). LSS tells them apart by serial number, the only part of their LSS
//! addresses that differs.

use od_core::devices::sgh50::{self, Channel, Sgh50, Variant};
use od_core::encoder::SensorFault;
use od_core::lss::LssState;
use od_core::node::Device;
use od_core::{Bitrate, Frame, NmtState, Node};
use tests_host::bus::{Bus, Sender};
use tests_host::encoder::{Sensed, Sensor};

const SERIAL_1: u32 = 0x0012_D687;
const SERIAL_2: u32 = 0x0012_D688;

/// One encoder of the pair, with the node-ID it ships with and its serial number.
fn encoder(channel: Channel, serial: u32, sensor: &Sensor) -> Sensed<Sgh50> {
    let variant = Variant::Redundant(channel);
    let mut node = Node::new(Sgh50::new(variant), variant.default_node_id(), Bitrate::K500);
    od_core::encoder::program_serial(&mut node.split().1.od, serial);
    Sensed::new(node, sensor.clone())
}

/// The pair on one bus, both measuring the same wire (µm), after their boot-ups.
fn pair(um: u32) -> (Bus, Sensor, Sensor) {
    let (s1, s2) = (Sensor::new(um), Sensor::new(um));
    let mut bus = Bus::new();
    bus.add(encoder(Channel::First, SERIAL_1, &s1));
    bus.add(encoder(Channel::Second, SERIAL_2, &s2));
    bus.expect(0x701, &[0x00]);
    bus.expect(0x702, &[0x00]);
    bus.expect_silence();
    (bus, s1, s2)
}

fn lss(bus: &mut Bus, data: [u8; 8]) {
    bus.send(Frame::std(0x7E5, &data));
}

fn state(bus: &mut Bus, n: usize) -> NmtState {
    bus.station(n).nmt().unwrap()
}

#[test]
fn two_nodes_boot_with_node_ids_1_and_2_and_identical_identity_but_serial() {
    let (mut bus, _, _) = pair(51_000);
    let (a, b) = (bus.station(0).core().od.clone(), bus.station(1).core().od.clone());
    for (index, sub) in [(0x1000, 0), (0x1018, 1), (0x1018, 2), (0x1018, 3), (0x6507, 0)] {
        assert_eq!(a.value(index, sub), b.value(index, sub), "{index:04X}h.{sub:02X}");
    }
    assert_eq!((a.value(0x1018, 4), b.value(0x1018, 4)), (Some(SERIAL_1), Some(SERIAL_2)));
    assert_eq!((a.value(0x650B, 0), b.value(0x650B, 0)), (Some(SERIAL_1), Some(SERIAL_2)));
    assert_eq!((a.value(0x5F0A, 1), b.value(0x5F0A, 1)), (Some(1), Some(2)));
    assert_eq!((a.value(0x1800, 1), b.value(0x1800, 1)), (Some(0x181), Some(0x182)));
    assert_eq!((a.value(0x1014, 0), b.value(0x1014, 0)), (Some(0x81), Some(0x82)));
    // Each measures on its own: both see the same wire.
    assert_eq!((a.value(0x6020, 1), b.value(0x6020, 1)), (Some(510), Some(510)));
    // The second encoder's factory default of 5F0Ah.01 is 2 (a restore keeps it off node 1).
    // One table for both: the second's dictionary takes 2 as its factory node-ID.
    let second = Sgh50::new(Variant::Redundant(Channel::Second));
    assert_eq!((second.table().as_ptr(), second.factory_node_id()), (sgh50::TABLE.as_ptr(), Some(2)));
    let e = b.entry(b.pos(0x5F0A, 1).unwrap());
    assert_eq!((a.default_of(e, 0), b.default_of(e, 0)), (1, 2));
}

#[test]
fn nmt_addresses_each_encoder_or_both() {
    let (mut bus, _, _) = pair(51_000);
    bus.send(Frame::std(0x000, &[0x01, 0x02]));
    assert_eq!((state(&mut bus, 0), state(&mut bus, 1)), (NmtState::PreOperational, NmtState::Operational));
    bus.send(Frame::std(0x000, &[0x01, 0x00]));
    assert_eq!((state(&mut bus, 0), state(&mut bus, 1)), (NmtState::Operational, NmtState::Operational));
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    assert_eq!((state(&mut bus, 0), state(&mut bus, 1)), (NmtState::PreOperational, NmtState::Operational));
}

#[test]
fn each_encoder_reports_its_own_sensor_errors() {
    let (mut bus, s1, s2) = pair(51_000);
    s2.fail(SensorFault::Diagnosis);
    bus.advance(1);
    let seen = bus.expect(0x082, &[0x05, 0xFF, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(seen.from, Sender::Node(1));
    bus.expect_silence();
    assert_eq!(bus.station(0).core().od.value(0x6503, 0), Some(0));
    assert_eq!(bus.station(1).core().od.value(0x6503, 0), Some(1));
    // Redundancy: encoder 1 still measures.
    s1.set(52_000);
    s2.heal();
    bus.advance(1);
    bus.expect(0x082, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(bus.station(0).core().od.value(0x6020, 1), Some(520));
}

#[test]
fn global_lss_inquiry_makes_both_answer_which_is_why_selection_is_by_serial() {
    let (mut bus, _, _) = pair(51_000);
    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x5D, 0, 0, 0, 0, 0, 0, 0]);
    let answers: Vec<_> = bus.drain().into_iter().map(|s| (s.from, s.frame.payload().to_vec())).collect();
    let (a, b) = (SERIAL_1.to_le_bytes(), SERIAL_2.to_le_bytes());
    assert_eq!(
        answers,
        vec![
            (Sender::Node(0), vec![0x5D, a[0], a[1], a[2], a[3], 0, 0, 0]),
            (Sender::Node(1), vec![0x5D, b[0], b[1], b[2], b[3], 0, 0, 0]),
        ]
    );
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
}

#[test]
fn lss_selects_encoder_2_by_serial_and_readdresses_it_alone() {
    let (mut bus, _, _) = pair(51_000);
    let s = SERIAL_2.to_le_bytes();
    // Digest 6.5 derived sequence, redundant-safe: all waiting, then select by the full address.
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x40, 0x95, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]);
    lss(&mut bus, [0x41, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    lss(&mut bus, [0x42, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00]);
    bus.expect_silence();
    lss(&mut bus, [0x43, s[0], s[1], s[2], s[3], 0x00, 0x00, 0x00]);
    let selected = bus.expect(0x7E4, &[0x44, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(selected.from, Sender::Node(1));
    bus.expect_silence();
    assert_eq!(bus.station(0).lss().unwrap().state(), LssState::Waiting);
    assert_eq!(bus.station(1).lss().unwrap().state(), LssState::Configuration);
    // Configure node-ID 5 and store: only encoder 2 answers.
    lss(&mut bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bus.expect(0x7E4, &[0x11, 0, 0, 0, 0, 0, 0, 0]).from, Sender::Node(1));
    lss(&mut bus, [0x17, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bus.expect(0x7E4, &[0x17, 0, 0, 0, 0, 0, 0, 0]).from, Sender::Node(1));
    bus.expect_silence();
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    // NMT reset communication of node 2 activates node-ID 5; encoder 1 stays on node 1.
    bus.send(Frame::std(0x000, &[0x82, 0x02]));
    bus.expect(0x705, &[0x00]);
    bus.expect_silence();
    assert_eq!((bus.station(0).core().node_id, bus.station(1).core().node_id), (1, 5));
    assert_eq!(bus.station(0).core().od.value(0x5F0A, 1), Some(1));
    // The moved encoder's EMCY follows its node-ID.
    assert_eq!(bus.station(1).core().od.value(0x1014, 0), Some(0x85));
}
