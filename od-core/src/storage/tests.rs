//! The node-side storage rules on the SGH10 dictionary: power-on from an image, merge, the
//! 1010h/1011h commands and what an NMT reset loads.

use super::*;
use crate::bitrate::Bitrate;
use crate::context::{Output, ResetKind, Written};
use crate::device::{CanopenDevice, Device};
use crate::devices::sgh10;
use crate::node::Node;
use crate::time::Instant;

struct Sgh10;
impl Device for Sgh10 {
    fn table(&self) -> &'static [Entry] {
        sgh10::TABLE
    }
}
impl CanopenDevice for Sgh10 {}

fn by_group(e: &Entry, mask: GroupMask) -> bool {
    mask.contains(e.group)
}

fn rec(index: u16, sub: u8, value: u32) -> Record {
    let od = Od::new(sgh10::TABLE, 1);
    Record::of(od.entry(od.pos(index, sub).unwrap()), value)
}

fn image(records: &[(u16, u8, u32)]) -> Image {
    let mut i = Image::new();
    for &(index, sub, value) in records {
        i.set(rec(index, sub, value)).unwrap();
    }
    i
}

fn boot(loaded: &Loaded) -> Node<Sgh10> {
    Node::boot(Sgh10, loaded)
}

fn value(node: &Node<Sgh10>, index: u16, sub: u8) -> u32 {
    node.core().od.value(index, sub).unwrap()
}

fn set(node: &mut Node<Sgh10>, index: u16, sub: u8, v: u32) {
    assert!(node.split().1.od.set_value(index, sub, v));
}

fn pos(index: u16, sub: u8) -> usize {
    Od::new(sgh10::TABLE, 1).pos(index, sub).unwrap()
}

#[test]
fn blank_and_invalid_flash_boot_with_factory_defaults() {
    for loaded in [Loaded::Blank, Loaded::Invalid] {
        let node = boot(&loaded);
        let core = node.core();
        assert_eq!((core.node_id, core.bitrate), (1, Bitrate::K500));
        assert_eq!(value(&node, 0x1014, 0), 0x81);
        assert_eq!(value(&node, 0x6401, 1), -20478i32 as u32);
        assert_eq!(core.storage.fault(), loaded == Loaded::Invalid);
    }
}

#[test]
fn image_sets_node_id_bit_rate_and_values_and_cob_ids_follow_the_node_id() {
    let i = image(&[(0x5F0A, 1, 5), (0x5F0A, 2, 3), (0x1017, 0, 100), (0x1800, 1, 0x190)]);
    let node = boot(&Loaded::Image(i));
    assert_eq!((node.core().node_id, node.core().bitrate), (5, Bitrate::K125));
    assert_eq!(value(&node, 0x1017, 0), 100);
    assert_eq!(value(&node, 0x1800, 1), 0x190, "a changed COB-ID stays");
    assert_eq!(value(&node, 0x1801, 1), 0x285, "a default COB-ID follows the node-ID");
    assert_eq!(value(&node, 0x1014, 0), 0x85);
}

#[test]
fn records_the_firmware_cannot_take_are_skipped() {
    let mut i = image(&[(0x1017, 0, 100)]);
    i.set(Record { index: 0x2222, sub: 0, size: 4, value: 1 }).unwrap(); // no such entry
    i.set(Record { index: 0x5F0A, sub: 1, size: 1, value: 200 }).unwrap(); // out of range
    i.set(Record { index: 0x6000, sub: 0, size: 4, value: 8 }).unwrap(); // wrong size
    i.set(Record { index: 0x1018, sub: 1, size: 4, value: 9 }).unwrap(); // not stored
    let node = boot(&Loaded::Image(i));
    assert_eq!(value(&node, 0x1017, 0), 100);
    assert_eq!(node.core().node_id, 1);
    assert_eq!(value(&node, 0x6000, 0), 4);
    assert_eq!(value(&node, 0x1018, 1), 0x195);
}

#[test]
fn new_is_boot_from_an_image_with_node_id_and_bit_rate() {
    let node = Node::new(Sgh10, 7, Bitrate::K250);
    assert_eq!((node.core().node_id, node.core().bitrate), (7, Bitrate::K250));
    assert_eq!(value(&node, 0x5F0A, 1), 7);
    assert_eq!(value(&node, 0x5F0A, 2), 4);
    assert_eq!(value(&node, 0x1014, 0), 0x87);
    assert!(!node.core().storage.fault());
}

#[test]
fn merge_takes_selected_groups_keeps_the_rest_and_leaves_defaults_out() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x1017, 0, 100); // comm
    set(&mut node, 0x6000, 0, 0x0C); // app
    set(&mut node, 0x5F0A, 1, 5); // manuf
    let stored = image(&[(0x6000, 0, 0x0C), (0x6002, 0, 5000), (0x100C, 0, 50)]);

    let mut i = stored.clone();
    merge(&mut i, &node.core().od, 1, GroupMask(Group::Comm.bit())).unwrap();
    assert_eq!(i, image(&[(0x1017, 0, 100), (0x6000, 0, 0x0C), (0x6002, 0, 5000)]), "100Ch back at default");

    let mut i = stored.clone();
    merge(&mut i, &node.core().od, 1, GroupMask::LSS).unwrap();
    assert_eq!(i, image(&[(0x100C, 0, 50), (0x5F0A, 1, 5), (0x6000, 0, 0x0C), (0x6002, 0, 5000)]));

    let mut i = stored;
    merge(&mut i, &node.core().od, 1, GroupMask::ALL).unwrap();
    assert_eq!(i, image(&[(0x1017, 0, 100), (0x5F0A, 1, 5), (0x6000, 0, 0x0C)]));
}

#[test]
fn merge_never_changes_factory_data() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x1018, 4, 4711);
    let mut i = Image::new();
    merge(&mut i, &node.core().od, 1, GroupMask::ALL).unwrap();
    assert_eq!(i.get(0x1018, 4).map(|r| r.value), Some(4711), "first save writes the serial number");
    set(&mut node, 0x1018, 4, 1234);
    merge(&mut i, &node.core().od, 1, GroupMask::ALL).unwrap();
    assert_eq!(i.get(0x1018, 4).map(|r| r.value), Some(4711), "and no save changes it");
}

#[test]
fn merge_drops_records_of_removed_entries() {
    let node = Node::new(Sgh10, 1, Bitrate::K500);
    let mut i = image(&[(0x6002, 0, 5000)]);
    i.set(Record { index: 0x2222, sub: 0, size: 4, value: 1 }).unwrap();
    merge(&mut i, &node.core().od, 1, GroupMask(Group::Comm.bit())).unwrap();
    assert_eq!(i, image(&[(0x6002, 0, 5000)]));
}

#[test]
fn store_checks_the_signature_and_defers() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    let core = node.split().1;
    assert_eq!(core.on_store(pos(0x1010, 1), 0x6576_6174), Err(Abort::CANNOT_STORE));
    assert_eq!(core.on_store(pos(0x1010, 1), LOAD), Err(Abort::CANNOT_STORE));
    assert!(core.out.is_empty());
    assert_eq!(core.on_store(pos(0x1010, 3), SAVE), Ok(Written::Deferred));
    assert_eq!(core.out.pop(), Some(Output::Store(GroupMask(Group::App.bit()))));
    assert_eq!(core.on_store(pos(0x1010, 1), SAVE), Err(Abort::DEVICE_STATE), "one at a time");
    core.store_done(false, Instant::ZERO);
    assert_eq!(core.on_store(pos(0x1010, 1), SAVE), Ok(Written::Deferred));
    assert_eq!(core.out.pop(), Some(Output::Store(GroupMask::ALL)));
}

#[test]
fn restore_checks_the_signature_and_waits_for_the_reset() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x1017, 0, 100);
    let core = node.split().1;
    assert_eq!(core.on_restore(pos(0x1011, 2), SAVE), Err(Abort::CANNOT_STORE));
    assert_eq!(core.storage.restore_pending(), GroupMask(0));
    assert_eq!(core.on_restore(pos(0x1011, 2), LOAD), Ok(Written::Done));
    assert_eq!(core.storage.restore_pending(), GroupMask(Group::Comm.bit()));
    assert_eq!(core.od.value(0x1017, 0), Some(100), "RAM unchanged until the reset");
    assert!(core.out.is_empty(), "flash unchanged");
}

#[test]
fn reset_node_reloads_stored_values_reset_communication_only_comm() {
    let i = image(&[(0x1017, 0, 100), (0x6002, 0, 5000)]);
    let mut node = boot(&Loaded::Image(i));
    set(&mut node, 0x1017, 0, 200);
    set(&mut node, 0x6002, 0, 6000);
    set(&mut node, 0x100C, 0, 10);
    node.split().1.reload(ResetKind::Communication, by_group);
    assert_eq!(value(&node, 0x1017, 0), 100);
    assert_eq!(value(&node, 0x100C, 0), 0);
    assert_eq!(value(&node, 0x6002, 0), 6000, "application untouched by 82h");
    node.split().1.reload(ResetKind::Node, by_group);
    assert_eq!(value(&node, 0x6002, 0), 5000);
}

#[test]
fn reset_keeps_the_pending_node_id_and_the_error_history() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x5F0A, 1, 5);
    set(&mut node, 0x1003, 0, 1);
    set(&mut node, 0x1003, 1, 0x8120);
    node.split().1.reload(ResetKind::Node, by_group);
    assert_eq!(value(&node, 0x5F0A, 1), 5);
    assert_eq!((value(&node, 0x1003, 0), value(&node, 0x1003, 1)), (1, 0x8120));
    assert_eq!(value(&node, 0x1014, 0), 0x85, "defaults follow the node-ID the reset activates");
}

#[test]
fn restore_then_any_reset_loads_defaults_of_every_restored_group() {
    let i = image(&[(0x1017, 0, 100), (0x6002, 0, 5000), (0x5F0A, 1, 9)]);
    let mut node = boot(&Loaded::Image(i));
    set(&mut node, 0x1003, 0, 1);
    set(&mut node, 0x1003, 1, 0x8120);
    let core = node.split().1;
    core.on_restore(pos(0x1011, 1), LOAD).unwrap();
    core.reload(ResetKind::Communication, by_group);
    assert_eq!(core.od.value(0x1017, 0), Some(0));
    assert_eq!(core.od.value(0x1003, 1), Some(0), "restoring comm clears the history");
    assert_eq!(core.od.value(0x1003, 0), Some(core.od.entry(pos(0x1003, 0)).default_value(1)));
    // 82h applies the restore of every group 1011h.01 named (D-STO-10).
    assert_eq!(core.od.value(0x6002, 0), Some(10239), "82h applies application defaults too");
    assert_eq!(core.od.value(0x5F0A, 1), Some(1), "node-ID back to its default");
    assert_eq!(core.od.value(0x1014, 0), Some(0x81));
    assert_eq!(core.storage.restore_pending(), GroupMask(0));
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x6002, 0), Some(5000), "applied: 81h loads the stored value");
    // Nothing was saved: the next reset loads the stored values again.
    core.od.set_value(0x1017, 0, 7);
    core.reload(ResetKind::Communication, by_group);
    assert_eq!(core.od.value(0x1017, 0), Some(100));
}

#[test]
fn a_successful_save_becomes_what_resets_load_and_keeps_a_restore() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x1017, 0, 100);
    set(&mut node, 0x6002, 0, 5000);
    let core = node.split().1;
    core.on_restore(pos(0x1011, 1), LOAD).unwrap();
    core.on_store(pos(0x1010, 2), SAVE).unwrap();
    core.store_done(true, Instant::ZERO);
    // The save does not cancel the restore (D-STO-10).
    assert_eq!(core.storage.restore_pending(), GroupMask::ALL);
    core.od.set_value(0x1017, 0, 7);
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x1017, 0), Some(0), "restored");
    assert_eq!(core.od.value(0x6002, 0), Some(10239), "restored");
    // The restore is applied; the save is what the next reset loads.
    core.od.set_value(0x1017, 0, 7);
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x1017, 0), Some(100), "saved");
}

#[test]
fn a_failed_save_changes_nothing() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x1017, 0, 100);
    let core = node.split().1;
    core.on_store(pos(0x1010, 1), SAVE).unwrap();
    core.store_done(false, Instant::ZERO);
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x1017, 0), Some(0));
}

#[test]
fn an_lss_store_saves_only_the_pending_entries() {
    let mut node = Node::new(Sgh10, 1, Bitrate::K500);
    set(&mut node, 0x5F0A, 2, 3);
    set(&mut node, 0x6002, 0, 5000);
    let core = node.split().1;
    core.request_store(GroupMask::LSS).unwrap();
    assert_eq!(core.out.pop(), Some(Output::Store(GroupMask::LSS)));
    core.store_done(true, Instant::ZERO);
    // Only the LSS entries were saved: a reset loads the application group's stored default.
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x6002, 0), Some(10239));
    assert_eq!(core.od.value(0x5F0A, 2), Some(3));
    core.on_restore(pos(0x1011, 4), LOAD).unwrap();
    core.reload(ResetKind::Node, by_group);
    assert_eq!(core.od.value(0x5F0A, 2), Some(5), "restore: back to the default code");
}

#[test]
fn a_device_may_widen_what_a_restore_covers() {
    // The AP10T's "bus parameters" (manual Table 4) include the node-ID in 5F0Ah.
    let bus_parameters =
        |e: &Entry, mask: GroupMask| mask.contains(e.group) || (mask.contains(Group::Comm) && e.index == 0x5F0A);
    let mut node = boot(&Loaded::Image(image(&[(0x5F0A, 1, 9), (0x6002, 0, 5000)])));
    let core = node.split().1;
    core.on_restore(pos(0x1011, 2), LOAD).unwrap();
    core.reload(ResetKind::Communication, bus_parameters);
    assert_eq!(core.od.value(0x5F0A, 1), Some(1));
    assert_eq!(core.od.value(0x1014, 0), Some(0x81), "defaults for the node-ID the reset activates");
    assert_eq!(core.od.value(0x6002, 0), Some(5000));
}

#[test]
fn user_bit_is_the_group_bit_of_the_user_groups() {
    for g in [Group::None, Group::Comm, Group::App, Group::Manuf, Group::Factory] {
        let expected = if matches!(g, Group::Comm | Group::App | Group::Manuf) { g.bit() } else { 0 };
        assert_eq!(user_bit(g), expected, "{g:?}");
    }
}
