//! Both TPDOs of the SGH encoders carry position and speed, 6 bytes (digest SGH10 6.2
//! "TPDOs", SGH50 6.3). Moved to `tests/` when the SDO server and the PDO service are on this
//! branch.

use od_core::devices::sgh10::{Sgh10, Variant};
use od_core::devices::sgh50::{Channel, Sgh50, Variant as Sgh50Variant};
use od_core::{Bitrate, CanId, Frame, Node};
use tests_host::bus::{Bus, Sender};
use tests_host::encoder::{sdo_write, Sensed, Sensor};

fn sgh10(um: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(um);
    let mut bus = Bus::new();
    bus.add(Sensed::new(Node::new(Sgh10::new(Variant::Sgh10), 1, Bitrate::K500), sensor.clone()));
    bus.expect(0x701, &[0x00]);
    (bus, sensor)
}

#[test]
fn tpdo1_every_100_ms_tpdo2_on_sync_and_rtr() {
    let (mut bus, sensor) = sgh10(51_000);
    bus.send(Frame::std(0x601, &[0x2B, 0x00, 0x18, 0x05, 0x64, 0x00, 0x00, 0x00]));
    bus.expect(0x581, &[0x60, 0x00, 0x18, 0x05, 0x00, 0x00, 0x00, 0x00]);
    // No PDO before OPERATIONAL.
    bus.advance(300);
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    let t0 = bus.now();
    bus.advance(100);
    let seen = bus.expect(0x181, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(seen.at, t0.add_millis(100));
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x281, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    bus.send(Frame { rtr: true, ..Frame::std(0x181, &[]) });
    bus.expect(0x181, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]);
    // −5 mm/s: bytes 4-5 FB FF.
    sensor.move_at(-5_000);
    bus.advance(100);
    bus.drain();
    bus.advance(100);
    let f = bus.recv().unwrap().frame;
    assert_eq!(f.id, CanId::Std(0x181));
    assert_eq!(&f.payload()[4..], &[0xFB, 0xFF]);
}

#[test]
fn one_sync_triggers_tpdo2_of_both_redundant_encoders() {
    let mut bus = Bus::new();
    for channel in [Channel::First, Channel::Second] {
        let v = Sgh50Variant::Redundant(channel);
        let node = Node::new(Sgh50::new(v), v.default_node_id(), Bitrate::K500);
        bus.add(Sensed::new(node, Sensor::new(51_000)));
    }
    bus.expect(0x701, &[0x00]);
    bus.expect(0x702, &[0x00]);
    sdo_write(&mut bus, 2, 0x6200, 0, 2, 0);
    bus.send(Frame::std(0x000, &[0x01, 0x00]));
    bus.send(Frame::std(0x080, &[]));
    assert_eq!(bus.expect(0x281, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]).from, Sender::Node(0));
    assert_eq!(bus.expect(0x282, &[0xFE, 0x01, 0x00, 0x00, 0x00, 0x00]).from, Sender::Node(1));
    bus.expect_silence();
}
