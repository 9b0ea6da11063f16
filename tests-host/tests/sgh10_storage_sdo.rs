//! SGH10 parameter storage on the bus through SDO: 1010h "save", 1011h "load", NMT resets and
//! power cycles, with the node's parameters in a flash (manual 4.7.2.11/4.7.2.12, digest 4 and
//! 6.2, decisions in docs/decisions.md "Parameter storage").
//!
//! PENDING: these scenarios need the SDO server (expedited transfers) and the EMCY producer,
//! which are built on other branches; with both they pass (checked against the services
//! branch's EMCY and a throwaway expedited SDO). Move this file to `tests-host/tests/` (or
//! append it to `tests/sgh10_storage.rs`) when both are on main.

use od_core::devices::sgh10;
use od_core::storage::{identity, Image, ParamFlash, Record, Region};
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::flash::{RamFlash, PAGE};
use tests_host::TableOnly;

/// Two 1 KiB pages, as the firmware reserves them.
const REGION: Region = Region { offset: 0, pages: 2 };

/// An SGH10 whose parameters live in `flash`; returns the bus with it as node 0.
fn bus_with(flash: RamFlash) -> Bus {
    let mut bus = Bus::new();
    let params = ParamFlash::new(flash, REGION, identity(sgh10::TABLE));
    bus.add_with_flash(params, |loaded| Node::boot(TableOnly(sgh10::TABLE), loaded));
    bus
}

fn blank() -> RamFlash {
    RamFlash::new(2)
}

/// SDO request to node-ID `id`, and the expected answer.
fn sdo(bus: &mut Bus, id: u16, req: [u8; 8], resp: [u8; 8]) {
    bus.send(Frame::std(0x600 + id, &req));
    bus.expect(0x580 + id, &resp);
}

const SAVE_ALL: [u8; 8] = [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65];
const SAVE_ALL_OK: [u8; 8] = [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0];
const LOAD_ALL: [u8; 8] = [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64];
const LOAD_ALL_OK: [u8; 8] = [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0];
const STORE_FAILED: [u8; 8] = [0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08];

/// 6002h (application) := 5000 and 100Ch (communication) := 50 on node 1.
fn change_both(bus: &mut Bus) {
    sdo(bus, 1, [0x23, 0x02, 0x60, 0x00, 0x88, 0x13, 0, 0], [0x60, 0x02, 0x60, 0x00, 0, 0, 0, 0]);
    sdo(bus, 1, [0x2B, 0x0C, 0x10, 0x00, 0x32, 0x00, 0, 0], [0x60, 0x0C, 0x10, 0x00, 0, 0, 0, 0]);
}

/// Reads 6002h and 100Ch of node 1 and checks them.
fn expect_values(bus: &mut Bus, total: u16, guard: u8) {
    let [t0, t1] = total.to_le_bytes();
    sdo(bus, 1, [0x40, 0x02, 0x60, 0x00, 0, 0, 0, 0], [0x43, 0x02, 0x60, 0x00, t0, t1, 0, 0]);
    sdo(bus, 1, [0x40, 0x0C, 0x10, 0x00, 0, 0, 0, 0], [0x4B, 0x0C, 0x10, 0x00, guard, 0, 0, 0]);
}

const DEFAULT_TOTAL: u16 = 10239;

#[test]
fn store_all_then_power_cycle_keeps_the_values() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    expect_values(&mut bus, 5000, 50);
}

#[test]
fn changes_without_save_are_lost_at_power_off() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
}

#[test]
fn store_of_one_group_keeps_the_other_as_stored() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    // 1010h.03: application parameters only.
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x03, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x03, 0, 0, 0, 0]);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 5000, 0);
    // Now communication only, with 6002h changed in RAM: 6002h stays as stored.
    sdo(&mut bus, 1, [0x23, 0x02, 0x60, 0x00, 0x70, 0x17, 0, 0], [0x60, 0x02, 0x60, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 1, [0x2B, 0x0C, 0x10, 0x00, 0x32, 0x00, 0, 0], [0x60, 0x0C, 0x10, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x02, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x02, 0, 0, 0, 0]);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 5000, 50);
}

#[test]
fn store_and_restore_entries_read_their_capabilities() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    for index in [0x10u8, 0x11] {
        sdo(&mut bus, 1, [0x40, index, 0x10, 0x00, 0, 0, 0, 0], [0x4F, index, 0x10, 0x00, 0x04, 0, 0, 0]);
        for sub in 1..=4 {
            sdo(&mut bus, 1, [0x40, index, 0x10, sub, 0, 0, 0, 0], [0x43, index, 0x10, sub, 0x01, 0, 0, 0]);
        }
    }
    // A "save" and a "load" are commands: the entries still read 1 afterwards.
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    sdo(&mut bus, 1, LOAD_ALL, LOAD_ALL_OK);
    sdo(&mut bus, 1, [0x40, 0x10, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x10, 0x10, 0x01, 0x01, 0, 0, 0]);
    sdo(&mut bus, 1, [0x40, 0x11, 0x10, 0x01, 0, 0, 0, 0], [0x43, 0x11, 0x10, 0x01, 0x01, 0, 0, 0]);
}

#[test]
fn wrong_signature_aborts_and_stores_nothing() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    // "savf", "SAVE", and "load" written to 1010h; "save" written to 1011h.
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x66], STORE_FAILED);
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x01, 0x53, 0x41, 0x56, 0x45], STORE_FAILED);
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x04, 0x6C, 0x6F, 0x61, 0x64], [0x80, 0x10, 0x10, 0x04, 0x20, 0, 0, 0x08]);
    sdo(&mut bus, 1, [0x23, 0x11, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65], [0x80, 0x11, 0x10, 0x01, 0x20, 0, 0, 0x08]);
    assert_eq!(bus.flash(0).ops(), 0, "the flash was not touched");
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
}

#[test]
fn restore_takes_effect_at_the_reset_and_lasts_only_if_saved() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    sdo(&mut bus, 1, LOAD_ALL, LOAD_ALL_OK);
    expect_values(&mut bus, 5000, 50);
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
    // Not saved: the next power-on loads the stored values again.
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 5000, 50);
    // Restore, reset, save: now the defaults are permanent.
    sdo(&mut bus, 1, LOAD_ALL, LOAD_ALL_OK);
    bus.send(Frame::std(0x000, &[0x81, 0x00]));
    bus.expect(0x701, &[0x00]);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
}

#[test]
fn restore_communication_and_reset_communication() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    sdo(&mut bus, 1, [0x23, 0x11, 0x10, 0x02, 0x6C, 0x6F, 0x61, 0x64], [0x60, 0x11, 0x10, 0x02, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 5000, 0);
}

#[test]
fn nmt_resets_load_the_stored_values() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    // Unsaved changes to both groups.
    sdo(&mut bus, 1, [0x23, 0x02, 0x60, 0x00, 0x70, 0x17, 0, 0], [0x60, 0x02, 0x60, 0x00, 0, 0, 0, 0]);
    sdo(&mut bus, 1, [0x2B, 0x0C, 0x10, 0x00, 0x64, 0x00, 0, 0], [0x60, 0x0C, 0x10, 0x00, 0, 0, 0, 0]);
    // Reset communication: the communication group comes back from storage.
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 6000, 50);
    // Reset node: the application group too.
    bus.send(Frame::std(0x000, &[0x81, 0x01]));
    bus.expect(0x701, &[0x00]);
    expect_values(&mut bus, 5000, 50);
}

#[test]
fn store_failure_aborts_and_keeps_the_old_parameters() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    change_both(&mut bus);
    sdo(&mut bus, 1, SAVE_ALL, SAVE_ALL_OK);
    sdo(&mut bus, 1, [0x23, 0x02, 0x60, 0x00, 0x70, 0x17, 0, 0], [0x60, 0x02, 0x60, 0x00, 0, 0, 0, 0]);
    // A worn-out flash, then a power cut in the middle of the save.
    bus.flash(0).set_worn(true);
    sdo(&mut bus, 1, SAVE_ALL, STORE_FAILED);
    bus.flash(0).set_worn(false);
    bus.flash(0).cut_after(5, Some(0x0F0F));
    sdo(&mut bus, 1, SAVE_ALL, STORE_FAILED);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    expect_values(&mut bus, 5000, 50);
    // A shell that reports the store failed (without touching the flash).
    bus.fail_stores(0, true);
    sdo(&mut bus, 1, SAVE_ALL, STORE_FAILED);
}

#[test]
fn node_id_change_store_reset_communication_boots_on_705h() {
    // Digest 6.2 "Node-ID change via 5F0Ah".
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    sdo(&mut bus, 1, [0x2F, 0x0A, 0x5F, 0x01, 0x05, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]);
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x04, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x705, &[0x00]);
    // The "+ node-ID" defaults follow: EMCY 85h, TPDO1 185h.
    sdo(&mut bus, 5, [0x40, 0x14, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x14, 0x10, 0x00, 0x85, 0, 0, 0]);
    sdo(&mut bus, 5, [0x40, 0x00, 0x18, 0x01, 0, 0, 0, 0], [0x43, 0x00, 0x18, 0x01, 0x85, 0x01, 0, 0]);
    sdo(&mut bus, 5, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0], [0x4F, 0x0A, 0x5F, 0x01, 0x05, 0, 0, 0]);
    // Stored: the node comes back as node 5 after a power cycle.
    bus.power_cycle(0);
    bus.expect(0x705, &[0x00]);
    // Stored with 1010h.01 as well, the COB-IDs at their defaults still follow the node-ID.
    sdo(&mut bus, 5, SAVE_ALL, SAVE_ALL_OK);
    sdo(&mut bus, 5, [0x2F, 0x0A, 0x5F, 0x01, 0x07, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x81, 0x05]));
    bus.expect(0x707, &[0x00]);
    sdo(&mut bus, 7, [0x40, 0x14, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x14, 0x10, 0x00, 0x87, 0, 0, 0]);
    // Not saved: node 5 again after a power cycle.
    bus.power_cycle(0);
    bus.expect(0x705, &[0x00]);
}

#[test]
fn bit_rate_change_store_reset_switches_the_node() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    // 5F0Ah.02 = 3 (125 kbit/s), store manufacturer group, reset communication.
    sdo(&mut bus, 1, [0x2F, 0x0A, 0x5F, 0x02, 0x03, 0, 0, 0], [0x60, 0x0A, 0x5F, 0x02, 0, 0, 0, 0]);
    sdo(&mut bus, 1, [0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65], [0x60, 0x10, 0x10, 0x04, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect_silence();
    assert_eq!(bus.node_bitrate(0), Bitrate::K125);
    bus.set_bitrate(Bitrate::K125);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K125);
}

#[test]
fn blank_flash_boots_with_defaults_and_reports_nothing() {
    let mut bus = bus_with(blank());
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
}

/// Boots from `flash`, expects defaults and the EMCY "data set" (6300h, 1001h bit 0), then a
/// save clears the condition (EMCY 0000h) and the next power-on is quiet.
fn boots_with_defaults_and_reports(flash: RamFlash) {
    let mut bus = bus_with(flash);
    bus.expect(0x701, &[0x00]);
    bus.expect(0x081, &[0x00, 0x63, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.expect_silence();
    expect_values(&mut bus, DEFAULT_TOTAL, 0);
    sdo(&mut bus, 1, [0x40, 0x01, 0x10, 0x00, 0, 0, 0, 0], [0x4F, 0x01, 0x10, 0x00, 0x01, 0, 0, 0]);
    bus.send(Frame::std(0x601, &SAVE_ALL));
    bus.expect(0x081, &[0x00; 8]);
    bus.expect(0x581, &SAVE_ALL_OK);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
}

#[test]
fn zeroed_flash_boots_with_defaults_and_reports_it() {
    boots_with_defaults_and_reports(RamFlash::from_bytes(vec![0; 2 * PAGE]));
}

#[test]
fn corrupt_flash_boots_with_defaults_and_reports_it() {
    let mut params = ParamFlash::new(RamFlash::new(2), REGION, identity(sgh10::TABLE));
    let mut image = Image::new();
    image.set(Record { index: 0x6002, sub: 0, size: 4, value: 5000 }).unwrap();
    params.write(&image).unwrap();
    let mut flash = params.into_inner();
    flash.bytes_mut()[36] ^= 0x01; // a bit of the record's value
    boots_with_defaults_and_reports(flash);
}

#[test]
fn foreign_flash_boots_with_defaults_and_reports_it() {
    let mut params = ParamFlash::new(RamFlash::new(2), REGION, 0x1234_5678);
    let mut image = Image::new();
    image.set(Record { index: 0x6002, sub: 0, size: 4, value: 5000 }).unwrap();
    params.write(&image).unwrap();
    boots_with_defaults_and_reports(params.into_inner());
}
