//! The hardware filters of each device: they pass exactly the frames its node lists
//! (`Node::rx_ids`), and every frame they reject is one the node ignores, in PRE-OPERATIONAL and
//! in OPERATIONAL, so the hardware loses nothing the core would have acted on.

use board_plan::filters::{accepted, banks, Bank, BANKS};
use od_core::devices::wv5800m::{Model, Turns, Variant, Wv5800m};
use od_core::devices::{sgh10, sgh50};
use od_core::node::{CanopenDevice, Node};
use od_core::{Bitrate, CanId, Frame, Instant, NmtState, RxId};

fn d(id: u16) -> RxId {
    RxId::data(CanId::Std(id))
}

fn r(id: u16) -> RxId {
    RxId::remote(CanId::Std(id))
}

fn sorted(mut ids: Vec<RxId>) -> Vec<RxId> {
    ids.sort();
    ids
}

fn filters_of<D: CanopenDevice>(node: &Node<D>) -> (Vec<RxId>, Vec<Bank>) {
    let ids = node.rx_ids();
    let b = banks(&ids, BANKS);
    (sorted(ids.to_vec()), b.to_vec())
}

/// Every identifier the node lists passes, and a sweep of every other 11-bit identifier (data
/// and remote) does not.
fn check_exact(ids: &[RxId], b: &[Bank]) {
    for id in 0..=0x7FFu16 {
        for rtr in [false, true] {
            let want = ids.contains(&RxId { id: CanId::Std(id), rtr });
            assert_eq!(accepted(b, CanId::Std(id), rtr), want, "{id:03X} rtr={rtr}");
        }
    }
}

/// The node after its boot-up (the PDO layer reads its configuration then), its outputs taken.
fn booted<D: CanopenDevice>(mut node: Node<D>) -> Node<D> {
    node.poll(Instant::ZERO);
    while node.next_output().is_some() {}
    node
}

fn sgh10(node_id: u8) -> Node<sgh10::Sgh10> {
    booted(Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10), node_id, Bitrate::K500))
}

fn wv5800m() -> Node<Wv5800m> {
    booted(Node::new(Wv5800m::new(Variant { model: Model::Wv, turns: Turns::Multi12 }), 1, Bitrate::K500))
}

#[test]
fn sgh10_default_node() {
    let node = sgh10(1);
    let (ids, b) = filters_of(&node);
    // NMT, SYNC, SDO, guarding RTR, LSS, and the two TPDOs, which answer a remote request.
    assert_eq!(ids, sorted(vec![d(0), d(0x80), r(0x181), r(0x281), d(0x601), r(0x701), d(0x7E5)]));
    assert_eq!(b.len(), 2);
    check_exact(&ids, &b);
}

#[test]
fn sgh10_follows_node_id_and_sync_cob_id() {
    let mut node = booted(Node::new(sgh10::Sgh10::new(sgh10::Variant::Sgh10L), 0x7F, Bitrate::K125));
    sdo_write(&mut node, 0x1005, 0, 0x0000_0099);
    let (ids, b) = filters_of(&node);
    assert_eq!(ids, sorted(vec![d(0), d(0x99), r(0x1FF), r(0x2FF), d(0x67F), r(0x77F), d(0x7E5)]));
    check_exact(&ids, &b);
    assert!(!accepted(&b, CanId::Std(0x80), false), "the old SYNC is gone");
}

#[test]
fn sgh10_extended_sync() {
    let mut node = sgh10(3);
    sdo_write(&mut node, 0x1005, 0, (1 << 29) | 0x001A_BCDE);
    let (ids, b) = filters_of(&node);
    assert!(ids.contains(&RxId::data(CanId::Ext(0x001A_BCDE))));
    assert_eq!(b.len(), 3, "six 11-bit identifiers in two banks, the 29-bit SYNC in a third");
    assert!(matches!(b[2], Bank::List32(_)));
    assert!(accepted(&b, CanId::Ext(0x001A_BCDE), false));
    assert!(!accepted(&b, CanId::Std(0x80), false));
}

#[test]
fn tpdo_without_remote_requests_is_not_received() {
    let mut node = sgh10(5);
    // 1800h.01 bit 30 set: TPDO1 answers no remote request (CiA 301).
    sdo_write(&mut node, 0x1800, 1, 0x4000_0185);
    let (ids, b) = filters_of(&node);
    assert!(!ids.contains(&r(0x185)));
    assert!(ids.contains(&r(0x285)));
    assert!(!accepted(&b, CanId::Std(0x185), true));
    check_exact(&ids, &b);
}

#[test]
fn sgh50_single_and_redundant_channels() {
    use sgh50::{Channel, Sgh50, Variant};
    for (variant, id) in
        [(Variant::Single, 1u16), (Variant::Redundant(Channel::First), 1), (Variant::Redundant(Channel::Second), 2)]
    {
        let node = booted(Node::new(Sgh50::new(variant), variant.default_node_id(), Bitrate::K500));
        let (ids, b) = filters_of(&node);
        for want in [d(0), d(0x80), d(0x600 + id), r(0x700 + id), d(0x7E5)] {
            assert!(ids.contains(&want), "{variant:?} {want:?}");
        }
        check_exact(&ids, &b);
    }
}

#[test]
fn wv5800m_default_node() {
    let node = wv5800m();
    let (ids, b) = filters_of(&node);
    for want in [d(0), d(0x80), d(0x601), r(0x701), d(0x7E5)] {
        assert!(ids.contains(&want), "{want:?}");
    }
    check_exact(&ids, &b);
}

#[test]
fn unconfigured_node_hears_lss_only() {
    let node = sgh10(0xFF);
    let (ids, b) = filters_of(&node);
    assert_eq!(ids, [d(0x7E5)]);
    assert_eq!(b.len(), 1);
    check_exact(&ids, &b);
}

/// Writes `value` to (index, sub) as a master does: an SDO expedited download of 4 bytes,
/// answered by the download response.
fn sdo_write<D: CanopenDevice>(node: &mut Node<D>, index: u16, sub: u8, value: u32) {
    let id = node.core().node_id as u16;
    let [i0, i1] = index.to_le_bytes();
    let [v0, v1, v2, v3] = value.to_le_bytes();
    node.on_frame(&Frame::std(0x600 + id, &[0x23, i0, i1, sub, v0, v1, v2, v3]), Instant::ZERO);
    let reply = Frame::std(0x580 + id, &[0x60, i0, i1, sub, 0, 0, 0, 0]);
    assert_eq!(node.next_output(), Some(od_core::Output::Frame(reply)), "write {index:04X}h.{sub}");
}

/// What a frame may change in a node, as far as the shell can see it.
fn snapshot<D: CanopenDevice>(node: &mut Node<D>) -> (NmtState, Vec<u32>, Option<Instant>, u32) {
    let od = &node.core().od;
    let values = (0..node.device().table().len()).map(|pos| od.get(pos)).collect();
    (node.nmt_state(), values, node.next_deadline(), node.rx_ids_generation())
}

/// Feeds the node every frame the filters reject (every 11-bit identifier as data with 0 and 8
/// bytes and as remote, and a few 29-bit ones) and checks that none has any effect: no output,
/// the same NMT state, dictionary, deadline and receive list.
fn rejected_frames_are_ignored<D: CanopenDevice>(node: &mut Node<D>, label: &str) {
    let b = banks(&node.rx_ids(), BANKS);
    let mut frames = Vec::new();
    for id in 0..=0x7FFu16 {
        frames.push(Frame::std(id, &[]));
        frames.push(Frame::std(id, &[0x2F, 0x00, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00]));
        frames.push(Frame::remote(CanId::Std(id), 8));
    }
    for id in [0x80, 0x185, 0x601, 0x701, 0x7E5, 0x18FF_0012, 0x1FFF_FFFF] {
        frames.push(Frame::new(CanId::Ext(id), &[0x01, 0x00]));
        frames.push(Frame::remote(CanId::Ext(id), 8));
    }
    let t = Instant::from_millis(1);
    let mut rejected = 0;
    for f in frames.iter().filter(|f| !accepted(&b, f.id, f.rtr)) {
        let before = snapshot(node);
        node.on_frame(f, t);
        assert_eq!(node.next_output(), None, "{label}: {f:?} made an output");
        assert!(snapshot(node) == before, "{label}: {f:?} changed the node");
        rejected += 1;
    }
    assert!(rejected > 3 * 0x7F0, "{label}: the sweep rejected {rejected} frames");
}

fn started<D: CanopenDevice>(node: &mut Node<D>, state: u8) {
    let id = node.core().node_id;
    node.on_frame(&Frame::std(0, &[state, id]), Instant::ZERO);
    while node.next_output().is_some() {}
}

#[test]
fn filters_lose_nothing_the_node_acts_on() {
    for state in [0x80, 0x01] {
        let label = if state == 0x01 { "operational" } else { "pre-operational" };
        let mut n = sgh10(1);
        started(&mut n, state);
        rejected_frames_are_ignored(&mut n, &format!("SGH10 {label}"));
        for variant in [sgh50::Variant::Single, sgh50::Variant::Redundant(sgh50::Channel::Second)] {
            let mut n = booted(Node::new(sgh50::Sgh50::new(variant), variant.default_node_id(), Bitrate::K500));
            started(&mut n, state);
            rejected_frames_are_ignored(&mut n, &format!("SGH50 {variant:?} {label}"));
        }
        let mut n = wv5800m();
        started(&mut n, state);
        rejected_frames_are_ignored(&mut n, &format!("WV5800M {label}"));
    }
}
