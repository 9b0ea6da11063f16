//! SGH10 power-on from its parameter flash on the bus: what the flash holds decides the node-ID
//! the boot-up goes out on, the bit rate, and the values (decisions in docs/decisions.md
//! "Parameter storage"). The 1010h/1011h scenarios through SDO are in
//! `tests-host/pending/sgh10_storage_sdo.rs` until the SDO server is on main.

use od_core::devices::sgh10;
use od_core::storage::{identity, Image, ParamFlash, Record, Region};
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::flash::{RamFlash, PAGE};
use tests_host::TableOnly;

/// Two 1 KiB pages, as the firmware reserves them.
const REGION: Region = Region { offset: 0, pages: 2 };

/// An SGH10 whose parameters live in `flash`, as node 0 of a bus at `bitrate`.
fn bus_with(flash: RamFlash, bitrate: Bitrate) -> Bus {
    let mut bus = Bus::new();
    bus.set_bitrate(bitrate);
    let params = ParamFlash::new(flash, REGION, identity(sgh10::TABLE));
    bus.add_with_flash(params, |loaded| Node::boot(TableOnly(sgh10::TABLE), loaded));
    bus
}

/// A flash holding an SGH10 image of these records, written as a save would.
fn stored(records: &[(u16, u8, u8, u32)]) -> RamFlash {
    let mut params = ParamFlash::new(RamFlash::new(2), REGION, identity(sgh10::TABLE));
    let mut image = Image::new();
    for &(index, sub, size, value) in records {
        image.set(Record { index, sub, size, value }).unwrap();
    }
    params.write(&image).unwrap();
    params.into_inner()
}

fn value(bus: &mut Bus, index: u16, sub: u8) -> u32 {
    bus.station(0).core().od.value(index, sub).unwrap()
}

#[test]
fn blank_flash_boots_on_node_1_with_defaults_and_reports_nothing() {
    let mut bus = bus_with(RamFlash::new(2), Bitrate::K500);
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    assert_eq!(value(&mut bus, 0x6002, 0), 10239);
    assert_eq!(value(&mut bus, 0x1014, 0), 0x81);
    assert!(!bus.station(0).core().storage.fault());
}

#[test]
fn stored_node_id_and_values_are_used_at_every_power_on() {
    let flash = stored(&[(0x5F0A, 1, 1, 5), (0x6002, 0, 4, 5000), (0x1800, 1, 4, 0x190)]);
    let mut bus = bus_with(flash, Bitrate::K500);
    bus.expect(0x705, &[0x00]);
    bus.expect_silence();
    assert_eq!(value(&mut bus, 0x6002, 0), 5000);
    assert_eq!(value(&mut bus, 0x1800, 1), 0x190, "a stored COB-ID stays");
    assert_eq!(value(&mut bus, 0x1801, 1), 0x285, "a default COB-ID follows the node-ID");
    bus.power_cycle(0);
    bus.expect(0x705, &[0x00]);
    // NMT addresses the stored node-ID; the resets keep it.
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x82, 0x05]));
    bus.expect(0x705, &[0x00]);
    bus.send(Frame::std(0x000, &[0x81, 0x00]));
    bus.expect(0x705, &[0x00]);
    assert_eq!(value(&mut bus, 0x6002, 0), 5000);
}

#[test]
fn stored_bit_rate_is_the_power_on_bit_rate() {
    // 5F0Ah.02 = 3: 125 kbit/s. A master at 500 kbit/s hears nothing.
    let mut bus = bus_with(stored(&[(0x5F0A, 2, 1, 3)]), Bitrate::K500);
    bus.expect_silence();
    assert_eq!(bus.node_bitrate(0), Bitrate::K125);
    bus.set_bitrate(Bitrate::K125);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
}

#[test]
fn a_power_cut_in_a_save_leaves_the_node_as_stored() {
    // The flash loses power in the middle of a save the shell performs; the node comes back
    // with what was stored before.
    let mut flash = stored(&[(0x6002, 0, 4, 5000)]);
    let mut params = ParamFlash::new(flash.clone(), REGION, identity(sgh10::TABLE));
    let mut other = Node::new(TableOnly(sgh10::TABLE), 1, Bitrate::K500);
    other.split().1.od.set_value(0x6002, 0, 6000);
    params.flash().cut_after(5, Some(0x00F0));
    assert!(params.save(other.core(), od_core::od::GroupMask::ALL).is_err());
    flash = params.into_inner();
    let mut bus = bus_with(flash, Bitrate::K500);
    bus.expect(0x701, &[0x00]);
    assert_eq!(value(&mut bus, 0x6002, 0), 5000);
}

/// Boots from `flash`: factory defaults, and the power-on fault that the EMCY 6300h reports.
fn boots_with_defaults_and_a_fault(flash: RamFlash) {
    let mut bus = bus_with(flash, Bitrate::K500);
    bus.expect(0x701, &[0x00]);
    assert_eq!(value(&mut bus, 0x6002, 0), 10239);
    assert_eq!(value(&mut bus, 0x5F0A, 1), 1);
    assert!(bus.station(0).core().storage.fault());
}

#[test]
fn zeroed_flash_boots_with_defaults() {
    boots_with_defaults_and_a_fault(RamFlash::from_bytes(vec![0; 2 * PAGE]));
}

#[test]
fn corrupt_flash_boots_with_defaults() {
    let mut flash = stored(&[(0x6002, 0, 4, 5000), (0x5F0A, 1, 1, 5)]);
    flash.bytes_mut()[36] ^= 0x01; // a bit of the first record's value
    boots_with_defaults_and_a_fault(flash);
}

#[test]
fn foreign_flash_boots_with_defaults() {
    let mut params = ParamFlash::new(RamFlash::new(2), REGION, identity(sgh10::TABLE) ^ 0x8000_0000);
    let mut image = Image::new();
    image.set(Record { index: 0x5F0A, sub: 1, size: 1, value: 5 }).unwrap();
    params.write(&image).unwrap();
    boots_with_defaults_and_a_fault(params.into_inner());
}
