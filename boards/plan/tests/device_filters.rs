//! The hardware filters of each device: exactly the identifiers its node handles.

use board_plan::filters::{accepted, banks, receive_ids, Bank, RxId, BANKS};
use od_core::devices::{sgh10, sgh50};
use od_core::node::{Device, Node};
use od_core::{Bitrate, CanId};

fn filters_of<D: Device>(node: &Node<D>) -> (Vec<RxId>, Vec<Bank>) {
    let ids = receive_ids(node.core());
    let b = banks(&ids, BANKS);
    (ids.to_vec(), b.to_vec())
}

/// Every identifier the node handles passes, and a sweep of every other 11-bit identifier
/// (data and remote) does not.
fn check_exact(ids: &[RxId], b: &[Bank]) {
    for id in 0..=0x7FFu16 {
        for rtr in [false, true] {
            let want = ids.contains(&RxId { id: CanId::Std(id), rtr });
            assert_eq!(accepted(b, CanId::Std(id), rtr), want, "{id:03X} rtr={rtr}");
        }
    }
}

#[test]
fn sgh10_default_node() {
    let node = Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10), 1, Bitrate::K500);
    let (ids, b) = filters_of(&node);
    assert_eq!(ids, [RxId::data(0), RxId::data(0x80), RxId::data(0x601), RxId::remote(0x701), RxId::data(0x7E5)]);
    assert_eq!(b.len(), 2);
    check_exact(&ids, &b);
}

#[test]
fn sgh10_follows_node_id_and_sync_cob_id() {
    let mut node = Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10L), 0x7F, Bitrate::K125);
    let (_, core) = node.split();
    assert!(core.od.set_value(0x1005, 0, 0x0000_0099));
    let (ids, b) = filters_of(&node);
    assert_eq!(ids, [RxId::data(0), RxId::data(0x99), RxId::data(0x67F), RxId::remote(0x77F), RxId::data(0x7E5)]);
    check_exact(&ids, &b);
    assert!(!accepted(&b, CanId::Std(0x80), false), "the old SYNC is gone");
}

#[test]
fn sgh10_extended_sync() {
    let mut node = Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10), 3, Bitrate::K250);
    let (_, core) = node.split();
    core.od.set_value(0x1005, 0, (1 << 29) | 0x001A_BCDE);
    let (ids, b) = filters_of(&node);
    assert!(ids.contains(&RxId { id: CanId::Ext(0x001A_BCDE), rtr: false }));
    assert_eq!(b.len(), 2, "four 11-bit identifiers in one bank, the 29-bit SYNC in another");
    assert!(matches!(b[1], Bank::List32(_)));
    assert!(accepted(&b, CanId::Ext(0x001A_BCDE), false));
    assert!(!accepted(&b, CanId::Std(0x80), false));
}

#[test]
fn sgh50_single_and_redundant_channels() {
    use sgh50::{Channel, Sgh50, Variant};
    for (variant, id) in
        [(Variant::Single, 1u16), (Variant::Redundant(Channel::First), 1), (Variant::Redundant(Channel::Second), 2)]
    {
        let node = Node::new(Sgh50::new(variant), variant.default_node_id(), Bitrate::K500);
        let (ids, b) = filters_of(&node);
        assert_eq!(
            ids,
            [RxId::data(0), RxId::data(0x80), RxId::data(0x600 + id), RxId::remote(0x700 + id), RxId::data(0x7E5)],
            "{variant:?}"
        );
        check_exact(&ids, &b);
    }
}

#[test]
fn unconfigured_node_hears_nmt_and_lss_only() {
    let node = Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10), 0xFF, Bitrate::K500);
    let (ids, b) = filters_of(&node);
    assert_eq!(ids, [RxId::data(0), RxId::data(0x7E5)]);
    assert_eq!(b.len(), 1);
    check_exact(&ids, &b);
}
