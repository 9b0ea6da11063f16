//! SGH10 SDO server on the bus: the manual's printed examples (digest 6.1 E1-E3) byte for byte,
//! and every failure the server answers with an abort (digest 3.6, CiA 301 §7.2.4.3.17).

use od_core::devices::sgh10;
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::TableOnly;

fn bus() -> Bus {
    let mut bus = Bus::new();
    bus.add(Node::new(TableOnly(sgh10::TABLE), 1, Bitrate::K500));
    bus.expect(0x701, &[0x00]);
    bus
}

fn req(bus: &mut Bus, data: [u8; 8]) {
    bus.send(Frame::std(0x601, &data));
}

#[test]
fn e1_expedited_read_of_the_calibration_value() {
    let mut bus = bus();
    req(&mut bus, [0x23, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
    bus.expect(0x581, &[0x60, 0x10, 0x60, 0x01, 0, 0, 0, 0]);
    req(&mut bus, [0x40, 0x10, 0x60, 0x01, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x43, 0x10, 0x60, 0x01, 0xFE, 0x01, 0x00, 0x00]);
}

#[test]
fn e2_expedited_two_byte_write_of_the_cycle_timer() {
    let mut bus = bus();
    req(&mut bus, [0x2B, 0x00, 0x62, 0x00, 0x94, 0x11, 0x00, 0x00]);
    bus.expect(0x581, &[0x60, 0x00, 0x62, 0x00, 0, 0, 0, 0]);
    req(&mut bus, [0x40, 0x00, 0x62, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x4B, 0x00, 0x62, 0x00, 0x94, 0x11, 0, 0]);
}

#[test]
fn e3_segmented_upload_of_the_device_name() {
    let mut bus = bus();
    req(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x41, 0x08, 0x10, 0x00, 0x05, 0, 0, 0]);
    req(&mut bus, [0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    // D-SDO-4: n = 2 unused bytes (05h), as CiA 301 requires for 5 bytes; the manual prints 03h.
    bus.expect(0x581, &[0x05, 0x53, 0x47, 0x48, 0x31, 0x30, 0x00, 0x00]);
    bus.expect_silence();
}

#[test]
fn one_byte_and_four_byte_reads_use_the_type_size() {
    let mut bus = bus();
    req(&mut bus, [0x40, 0x01, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x4F, 0x01, 0x10, 0x00, 0, 0, 0, 0]);
    req(&mut bus, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x0A, 0x00]);
    req(&mut bus, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0, 0]);
}

fn abort(index: u16, sub: u8, code: u32) -> [u8; 8] {
    let i = index.to_le_bytes();
    let c = code.to_le_bytes();
    [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
}

#[test]
fn failures_answer_with_the_cia_301_abort_codes() {
    let mut bus = bus();
    // Unknown object, unknown sub-index.
    req(&mut bus, [0x40, 0x00, 0x30, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x3000, 0, 0x0602_0000));
    req(&mut bus, [0x40, 0x00, 0x18, 0x04, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1800, 4, 0x0609_0011));
    // Write to read-only and const entries.
    req(&mut bus, [0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4]);
    bus.expect(0x581, &abort(0x1000, 0, 0x0601_0002));
    req(&mut bus, [0x2F, 0x01, 0x10, 0x00, 1, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1001, 0, 0x0601_0002));
    // Length too high / too low for the 16-bit 1017h.
    req(&mut bus, [0x23, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1017, 0, 0x0607_0012));
    req(&mut bus, [0x2F, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1017, 0, 0x0607_0013));
    // Out of range: 1017h 1..9 ms (the manual's only abort for a range is 06090030h).
    req(&mut bus, [0x2B, 0x17, 0x10, 0x00, 0x05, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1017, 0, 0x0609_0030));
    // Wrong "save" signature.
    req(&mut bus, [0x23, 0x10, 0x10, 0x01, b'x', b'a', b'v', b'e']);
    bus.expect(0x581, &abort(0x1010, 1, 0x0800_0020));
    // Block transfer and unknown command specifiers.
    req(&mut bus, [0xA0, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1008, 0, 0x0504_0001));
    req(&mut bus, [0xC0, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1008, 0, 0x0504_0001));
    req(&mut bus, [0xE0, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1008, 0, 0x0504_0001));
    // A segment request with no transfer in progress.
    req(&mut bus, [0x60, 0, 0, 0, 0, 0, 0, 0]);
    let seen = bus.recv().expect("an abort");
    assert_eq!(&seen.frame.data[..1], &[0x80]);
    assert_eq!(&seen.frame.data[4..], &0x0504_0001u32.to_le_bytes());
    // Nothing above was written.
    req(&mut bus, [0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x4B, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
}

#[test]
fn toggle_error_and_timeout_abort_a_segmented_upload() {
    let mut bus = bus();
    req(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x41, 0x08, 0x10, 0x00, 0x05, 0, 0, 0]);
    req(&mut bus, [0x70, 0, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1008, 0, 0x0503_0000));

    req(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x41, 0x08, 0x10, 0x00, 0x05, 0, 0, 0]);
    bus.advance(999);
    bus.expect_silence();
    bus.advance(1);
    bus.expect(0x581, &abort(0x1008, 0, 0x0504_0000));
    // The transfer is over: a segment request now is out of place.
    req(&mut bus, [0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bus.recv().expect("an abort").frame.data[0], 0x80);
}

#[test]
fn a_client_abort_ends_the_transfer_silently() {
    let mut bus = bus();
    req(&mut bus, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x41, 0x08, 0x10, 0x00, 0x05, 0, 0, 0]);
    req(&mut bus, abort(0x1008, 0, 0x0504_0000));
    bus.advance(2000);
    bus.expect_silence();
}

#[test]
fn segmented_download_writes_the_whole_value_at_the_end() {
    let mut bus = bus();
    // 1017h = 1000 ms by segmented download, size indicated 2.
    req(&mut bus, [0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0]);
    bus.expect(0x581, &[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    req(&mut bus, [0x0B, 0xE8, 0x03, 0, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x20, 0, 0, 0, 0, 0, 0, 0]);
    // Size mismatch: nothing written.
    req(&mut bus, [0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0]);
    bus.expect(0x581, &[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    req(&mut bus, [0x0D, 0x10, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1017, 0, 0x0607_0010));
    // Toggle error in the second segment.
    req(&mut bus, [0x21, 0x14, 0x10, 0x00, 4, 0, 0, 0]);
    bus.expect(0x581, &[0x60, 0x14, 0x10, 0x00, 0, 0, 0, 0]);
    req(&mut bus, [0x0C, 0x81, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x20, 0, 0, 0, 0, 0, 0, 0]);
    req(&mut bus, [0x0D, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x581, &abort(0x1014, 0, 0x0503_0000));
    req(&mut bus, [0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect(0x581, &[0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0]);
}

#[test]
fn no_sdo_in_stopped() {
    let mut bus = bus();
    bus.send(Frame::std(0x000, &[0x02, 0x01]));
    req(&mut bus, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    bus.expect_silence();
}
