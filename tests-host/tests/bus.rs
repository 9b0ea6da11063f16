//! The virtual bus itself: boot-up, NMT and time.

use od_core::devices::sgh10;
use od_core::{Bitrate, Frame, NmtState, Node};
use tests_host::bus::Bus;
use tests_host::TableOnly;

fn sgh10(node_id: u8) -> Node<TableOnly> {
    Node::new(TableOnly(sgh10::TABLE), node_id, Bitrate::K500)
}

#[test]
fn boot_up_then_nmt_commands() {
    let mut bus = Bus::new();
    bus.add(sgh10(1));
    bus.expect(0x701, &[0x00]);
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x701, &[0x00]);
    bus.send(Frame::std(0x000, &[0x81, 0x00]));
    bus.expect(0x701, &[0x00]);
    bus.send(Frame::std(0x000, &[0x01, 0x02]));
    bus.advance(1000);
    bus.expect_silence();
}

#[test]
fn nodes_boot_in_order_and_only_the_addressed_one_reacts() {
    let mut bus = Bus::new();
    bus.add(sgh10(1));
    bus.add(sgh10(2));
    bus.expect(0x701, &[0x00]);
    bus.expect(0x702, &[0x00]);
    bus.send(Frame::std(0x000, &[0x82, 0x02]));
    bus.expect(0x702, &[0x00]);
    bus.expect_silence();
}

#[test]
fn nmt_state_machine() {
    let mut node = sgh10(5);
    let t = od_core::Instant::ZERO;
    node.poll(t);
    assert_eq!(node.nmt_state(), NmtState::PreOperational);
    for (cs, state) in [
        (0x01, NmtState::Operational),
        (0x02, NmtState::Stopped),
        (0x80, NmtState::PreOperational),
        (0x02, NmtState::Stopped),
        (0x01, NmtState::Operational),
        (0x80, NmtState::PreOperational),
    ] {
        node.on_frame(&Frame::std(0, &[cs, 5]), t);
        assert_eq!(node.nmt_state(), state);
    }
    node.on_frame(&Frame::std(0, &[0x01, 6]), t);
    assert_eq!(node.nmt_state(), NmtState::PreOperational);
}
