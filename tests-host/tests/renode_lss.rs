//! What the Renode Robot test "LSS Fastscan Should Find Both SGH50 Boards By Their Serial
//! Numbers" (renode/tests/bench.robot) relies on, on the virtual bus: the two channels of a
//! redundant SGH50 (node-IDs 1 and 2) lose their node-IDs by LSS alone (switch global
//! configuration, configure node-ID FFh, switch global waiting, NMT reset communication), are
//! then silent, and both take part in the next Fastscan.

use od_core::devices::sgh50;
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::TableOnly;

fn channel(table: &'static [od_core::od::Entry], node_id: u8, serial: u32) -> Node<TableOnly> {
    let mut node = Node::new(TableOnly(table), node_id, Bitrate::K500);
    assert!(node.split().1.od.set_value(0x1018, 4, serial));
    node
}

fn lss(bus: &mut Bus, data: [u8; 8]) {
    bus.send(Frame::std(0x7E5, &data));
}

#[test]
fn the_sgh50_pair_is_unconfigured_by_lss_and_found_by_fastscan() {
    let mut bus = Bus::new();
    // The serial numbers sgh50.resc's unique IDs give (renode_files.rs checks them).
    bus.add(channel(sgh50::TABLE, 1, 0x6255_2812));
    bus.add(channel(sgh50::TABLE, 2, 0xF9F0_647D));
    bus.expect(0x701, &[0x00]);
    bus.expect(0x702, &[0x00]);
    bus.expect_silence();

    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
    lss(&mut bus, [0x11, 0xFF, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x11, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x11, 0, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x82, 0x00]));
    bus.advance(1000);
    // No node-ID: no boot-up, no heartbeat, NMT cannot reach them.
    bus.expect_silence();

    // The Fastscan restart: both confirm.
    lss(&mut bus, [0x51, 0, 0, 0, 0, 0x80, 0, 0]);
    bus.expect(0x7E4, &[0x4F, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x4F, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect_silence();
    // They differ in the serial number only: vendor, product and revision are one.
    let mut parts = |n: usize| {
        let od = &bus.station(n).core().od;
        (od.value(0x1018, 1), od.value(0x1018, 2), od.value(0x1018, 3))
    };
    let (a, b) = (parts(0), parts(1));
    assert_eq!(a, b);
}
