//! Issue 13, "Core and devices" (points 8 to 14): what an integrator trips over on the SGH10,
//! SGH50 and WV5800M, driven from the bus only (SDO, NMT and LSS frames byte for byte, the
//! sensor through `tests_host::encoder::Sensor`). Each test failed before its fix; the
//! decisions are in docs/decisions.md (the entries citing "issue 13 point N").

use od_core::devices::sgh10::{self, Sgh10};
use od_core::devices::sgh50::{self, Sgh50};
use od_core::devices::wv5800m::{self, Model, Turns, Wv5800m};
use od_core::encoder::Encoder;
use od_core::{Bitrate, Frame, Node};
use tests_host::bus::Bus;
use tests_host::encoder::{sdo_read, sdo_write, Sensed, Sensor};

/// The three CiA 406 encoders of the issue, each as a node with `node_id` (FFh: unconfigured,
/// LSS only) on a fresh bus, its sensor at a valid reading, after its boot-up message. The
/// closure gets the device's name and the bus.
fn each_encoder(node_id: u8, mut check: impl FnMut(&str, &mut Bus)) {
    fn on_bus<E: Encoder + od_core::node::CanopenDevice + 'static>(node: Node<E>, raw: u32) -> Bus {
        let mut bus = Bus::new();
        bus.add(Sensed::new(node, Sensor::new(raw)));
        bus
    }
    let wv = wv5800m::Variant { model: Model::Wv, turns: Turns::Multi12 };
    let mut buses = [
        ("SGH10", on_bus(Node::new(Sgh10::new(sgh10::Variant::Sgh10), node_id, Bitrate::K500), 51_000)),
        ("SGH50", on_bus(Node::new(Sgh50::new(sgh50::Variant::Single), node_id, Bitrate::K500), 51_000)),
        ("WV5800M", on_bus(Node::new(Wv5800m::new(wv), node_id, Bitrate::K500), 1000)),
    ];
    for (name, bus) in &mut buses {
        if node_id != 0xFF {
            bus.expect(0x700 + node_id as u16, &[0x00]);
        }
        bus.expect_silence();
        check(name, bus);
    }
}

/// NMT command `cs` to `node` (0: all).
fn nmt(bus: &mut Bus, cs: u8, node: u8) {
    bus.send(Frame::std(0x000, &[cs, node]));
}

/// An LSS request on 7E5h.
fn lss(bus: &mut Bus, data: [u8; 8]) {
    bus.send(Frame::std(0x7E5, &data));
}

// Point 8: 1200h sub 1/2 name the SDO identifiers in use (manuals: SGH10 4.7.2.16, SGH50
// 4.7.2.16, WV5800M 5.7.2.16 "Default 00000600h + Node-ID", and the identifier tables of
// §4.1 / §5.1: "SDO (rx) 600h + Node-ID").

#[test]
fn sdo_cob_ids_follow_a_node_id_changed_by_5f0ah_and_reset() {
    each_encoder(1, |name, bus| {
        assert_eq!(sdo_read(bus, 1, 0x1200, 1), 0x601, "{name}");
        assert_eq!(sdo_read(bus, 1, 0x1200, 2), 0x581, "{name}");
        // 5F0Ah.01 = 5, then NMT Reset Communication: the node is node 5 (manual 4.1 "after
        // re-initialization").
        sdo_write(bus, 1, 0x5F0A, 1, 1, 5);
        nmt(bus, 0x82, 1);
        bus.expect(0x705, &[0x00]);
        assert_eq!(sdo_read(bus, 5, 0x1200, 1), 0x605, "{name}: 1200h.01 after 82h");
        assert_eq!(sdo_read(bus, 5, 0x1200, 2), 0x585, "{name}: 1200h.02 after 82h");
        // And again with Reset Node.
        sdo_write(bus, 5, 0x5F0A, 1, 1, 0x7F);
        nmt(bus, 0x81, 5);
        bus.expect(0x77F, &[0x00]);
        assert_eq!(sdo_read(bus, 0x7F, 0x1200, 1), 0x67F, "{name}: 1200h.01 after 81h");
        assert_eq!(sdo_read(bus, 0x7F, 0x1200, 2), 0x5FF, "{name}: 1200h.02 after 81h");
    });
}

#[test]
fn sdo_cob_ids_of_a_node_commissioned_from_unconfigured_by_lss() {
    // Powered on unconfigured (a stored node-ID FFh, as LSS leaves it): it answers LSS only.
    each_encoder(0xFF, |name, bus| {
        bus.advance(100);
        bus.expect_silence();
        // Commissioning (CiA 305): configuration state, node-ID 0Ah, back to waiting: the
        // node activates the node-ID itself and boots up.
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x11, 0x0A, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x11, 0x00, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x70A, &[0x00]);
        bus.send(Frame::std(0x60A, &[0x40, 0x00, 0x12, 0x01, 0, 0, 0, 0]));
        bus.expect(0x58A, &[0x43, 0x00, 0x12, 0x01, 0x0A, 0x06, 0x00, 0x00]);
        bus.send(Frame::std(0x60A, &[0x40, 0x00, 0x12, 0x02, 0, 0, 0, 0]));
        bus.expect(0x58A, &[0x43, 0x00, 0x12, 0x02, 0x8A, 0x05, 0x00, 0x00]);
        bus.expect_silence();
        // Unconfigured again (FFh and 82h), then node-ID 0Bh the same way.
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x11, 0xFF, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x11, 0x00, 0, 0, 0, 0, 0, 0]);
        nmt(bus, 0x82, 0x0A);
        bus.advance(100);
        bus.expect_silence();
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x11, 0x0B, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x11, 0x00, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x70B, &[0x00]);
        assert_eq!(sdo_read(bus, 0x0B, 0x1200, 1), 0x60B, "{name}");
        assert_eq!(sdo_read(bus, 0x0B, 0x1200, 2), 0x58B, "{name}");
    });
}

// Point 9: an LSS-configured bit rate takes effect through LSS activate bit timing (15h) or a
// power cycle only (CiA 305; SGH10/SGH50 4.6.2.2, WV5800M 5.6.2.2: "To activate the new baud
// rate the Activate baud rate ... command must be executed ... Another possibility ... power
// off/on after Store configuration"); a 5F0Ah.02 write keeps "adoption ... only after
// re-initialization" (SGH10 4.1, WV5800M 5.1).

#[test]
fn nmt_resets_apply_an_lss_node_id_but_not_an_lss_bit_rate() {
    each_encoder(1, |name, bus| {
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x11, 0x05, 0, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x11, 0x00, 0, 0, 0, 0, 0, 0]);
        // Table index 4: 125 kbit/s.
        lss(bus, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x13, 0x00, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        // 82h activates the node-ID; the node boots up on node 5 at 500 kbit/s.
        nmt(bus, 0x82, 1);
        bus.expect(0x705, &[0x00]);
        assert_eq!(bus.node_bitrate(0), Bitrate::K500, "{name}: 82h");
        nmt(bus, 0x81, 5);
        bus.expect(0x705, &[0x00]);
        assert_eq!(bus.node_bitrate(0), Bitrate::K500, "{name}: 81h");
        bus.expect_silence();
        // The configured rate is still pending: activate bit timing (d1 = d2 = 10 ms) applies it.
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x15, 0x0A, 0x00, 0, 0, 0, 0, 0]);
        bus.advance(10);
        assert_eq!(bus.node_bitrate(0), Bitrate::K125, "{name}: 15h");
        bus.set_bitrate(Bitrate::K125);
        bus.advance(10);
        bus.expect(0x705, &[0x00]);
        // Applied: a reset keeps it.
        nmt(bus, 0x82, 5);
        bus.expect(0x705, &[0x00]);
        assert_eq!(bus.node_bitrate(0), Bitrate::K125, "{name}: 82h after 15h");
    });
}

#[test]
fn a_5f0ah_bit_rate_write_after_an_lss_one_is_adopted_at_the_reset() {
    each_encoder(1, |name, bus| {
        lss(bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0]);
        bus.expect(0x7E4, &[0x13, 0x00, 0, 0, 0, 0, 0, 0]);
        lss(bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        // 5F0Ah.02 reads the pending code (3 = 125 kbit/s); the SDO write of 4 (250 kbit/s)
        // is the manual's "after re-initialization".
        assert_eq!(sdo_read(bus, 1, 0x5F0A, 2), 3, "{name}");
        sdo_write(bus, 1, 0x5F0A, 2, 1, 4);
        nmt(bus, 0x82, 1);
        bus.expect_silence();
        assert_eq!(bus.node_bitrate(0), Bitrate::K250, "{name}");
    });
}

#[test]
fn a_stored_lss_bit_rate_waits_for_the_power_cycle() {
    use od_core::storage::{identity, ParamFlash, Region};
    use tests_host::flash::RamFlash;
    let params = ParamFlash::new(RamFlash::new(2), Region { offset: 0, pages: 2 }, identity(sgh10::TABLE));
    let mut bus = Bus::new();
    bus.add_with_flash(params, |loaded| Node::boot(tests_host::TableOnly(sgh10::TABLE), loaded));
    bus.expect(0x701, &[0x00]);
    lss(&mut bus, [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x13, 0x00, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x17, 0x00, 0, 0, 0, 0, 0, 0]);
    bus.expect(0x7E4, &[0x17, 0x00, 0, 0, 0, 0, 0, 0]);
    lss(&mut bus, [0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    nmt(&mut bus, 0x82, 0);
    bus.expect(0x701, &[0x00]);
    nmt(&mut bus, 0x81, 0);
    bus.expect(0x701, &[0x00]);
    assert_eq!(bus.node_bitrate(0), Bitrate::K500);
    bus.power_cycle(0);
    assert_eq!(bus.node_bitrate(0), Bitrate::K125);
    bus.set_bitrate(Bitrate::K125);
    bus.power_cycle(0);
    bus.expect(0x701, &[0x00]);
}

// Point 10: a 1011h restore is applied by the next NMT reset, 81h or 82h, for every group it
// named (manuals 4.7.2.12 / 5.7.2.12: 'The string "load" must be sent ... and reset executed
// thereafter'); a save before that reset does not cancel it.

const SAVE_ALL: [u8; 8] = [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65];
const LOAD_ALL: [u8; 8] = [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64];

/// 100Ch (communication) := 50 and 6200h (application, the TPDO1 cycle) := 100 on node 1,
/// saved with 1010h.01.
fn change_and_save(bus: &mut Bus) {
    sdo_write(bus, 1, 0x100C, 0, 2, 50);
    sdo_write(bus, 1, 0x6200, 0, 2, 100);
    bus.send(Frame::std(0x601, &SAVE_ALL));
    bus.expect(0x581, &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
}

#[test]
fn a_restore_of_all_groups_is_applied_by_reset_communication() {
    each_encoder(1, |name, bus| {
        change_and_save(bus);
        bus.send(Frame::std(0x601, &LOAD_ALL));
        bus.expect(0x581, &[0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
        nmt(bus, 0x82, 1);
        bus.expect(0x701, &[0x00]);
        assert_eq!(sdo_read(bus, 1, 0x100C, 0), 0, "{name}: communication group");
        assert_eq!(sdo_read(bus, 1, 0x6200, 0), 0, "{name}: application group by 82h too");
        assert_eq!(sdo_read(bus, 1, 0x1800, 5), 0, "{name}");
        // Applied: the next 81h loads the stored values again.
        nmt(bus, 0x81, 1);
        bus.expect(0x701, &[0x00]);
        assert_eq!(sdo_read(bus, 1, 0x100C, 0), 50, "{name}");
        assert_eq!(sdo_read(bus, 1, 0x6200, 0), 100, "{name}");
    });
}

#[test]
fn a_save_after_a_restore_does_not_cancel_it() {
    each_encoder(1, |name, bus| {
        sdo_write(bus, 1, 0x100C, 0, 2, 50);
        sdo_write(bus, 1, 0x6200, 0, 2, 100);
        bus.send(Frame::std(0x601, &LOAD_ALL));
        bus.expect(0x581, &[0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
        bus.send(Frame::std(0x601, &SAVE_ALL));
        bus.expect(0x581, &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
        nmt(bus, 0x81, 1);
        bus.expect(0x701, &[0x00]);
        assert_eq!(sdo_read(bus, 1, 0x100C, 0), 0, "{name}");
        assert_eq!(sdo_read(bus, 1, 0x6200, 0), 0, "{name}");
    });
}

// Point 11: the SGH10's EMCY FF12h "speed error" (manual Table 9, conditions not stated, digest
// A21/A27) is raised when the speed value cannot be represented in 6030h.01 at the step width
// 6005h.02 (it saturates), never for a sensor fault: FF05h "position value error" reports that.

fn emcy(code: u16, register: u8) -> [u8; 8] {
    let c = code.to_le_bytes();
    [c[0], c[1], register, 0, 0, 0, 0, 0]
}

fn sgh10_on_bus(um: u32) -> (Bus, Sensor) {
    let sensor = Sensor::new(um);
    let mut bus = Bus::new();
    let node = Node::new(Sgh10::new(sgh10::Variant::Sgh10), 1, Bitrate::K500);
    bus.add(Sensed::new(node, sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus.expect_silence();
    (bus, sensor)
}

#[test]
fn sgh10_sensor_fault_raises_ff05h_and_no_speed_error() {
    let (mut bus, sensor) = sgh10_on_bus(51_000);
    bus.advance(200);
    sensor.fail(od_core::encoder::SensorFault::Diagnosis);
    bus.advance(1);
    bus.expect(0x081, &emcy(0xFF05, 0x81));
    bus.expect_silence();
    bus.advance(100);
    bus.expect_silence();
    sensor.heal();
    bus.advance(1);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    // A whole integration time later the speed is valid again: nothing to report.
    bus.advance(200);
    bus.expect_silence();
    assert_eq!(sdo_read(&mut bus, 1, 0x1003, 0), 1);
    assert_eq!(sdo_read(&mut bus, 1, 0x1003, 1), 0xFF05);
    // A reading beyond the measuring range is a sensor fault too: FF05h alone.
    sensor.set(1_024_000);
    bus.advance(1);
    bus.expect(0x081, &emcy(0xFF05, 0x81));
    bus.expect_silence();
}

/// An SGH10 whose wire could be pulled faster than 6030h.01 can show (the real drum cannot:
/// 1023.9 mm in one 100 ms window is 10239 mm/s, within INTEGER16 at 1 mm/s): the SGH10's
/// dictionary and rules, with a measuring range wide enough to saturate the speed.
struct FastSgh10(od_core::encoder::linear::Linear);

impl od_core::node::Device for FastSgh10 {
    fn table(&self) -> &'static [od_core::od::Entry] {
        sgh10::TABLE
    }
    fn on_write(
        &mut self,
        core: &mut od_core::node::Core,
        pos: usize,
        value: u32,
        now: od_core::Instant,
    ) -> Result<(), od_core::Abort> {
        self.0.on_write(core, pos, value, now)
    }
    fn on_reset(&mut self, core: &mut od_core::node::Core, kind: od_core::node::ResetKind, now: od_core::Instant) {
        self.0.on_reset(core, kind, now);
    }
    fn poll(&mut self, core: &mut od_core::node::Core, now: od_core::Instant) {
        self.0.poll(core, now);
    }
}

impl od_core::node::CanopenDevice for FastSgh10 {}

impl Encoder for FastSgh10 {
    fn on_sample(
        &mut self,
        core: &mut od_core::node::Core,
        raw: Result<u32, od_core::encoder::SensorFault>,
        now: od_core::Instant,
    ) {
        self.0.on_sample(core, raw, now);
    }
    fn sample_period_us(&self) -> u32 {
        sgh10::SPEC.sample_period_us
    }
}

#[test]
fn sgh10_speed_beyond_integer16_raises_ff12h_until_it_fits_again() {
    let spec = od_core::encoder::linear::LinearSpec { max_steps: i32::MAX as i64, ..sgh10::SPEC };
    let sensor = Sensor::new(0);
    let mut bus = Bus::new();
    let mut node = Node::new(FastSgh10(od_core::encoder::linear::Linear::new(spec)), 1, Bitrate::K500);
    // Work areas as wide as the position value, so that only the speed is judged.
    for k in 1..=2 {
        assert!(node.split().1.od.set_value(0x6401, k, i32::MIN as u32));
        assert!(node.split().1.od.set_value(0x6402, k, i32::MAX as u32));
    }
    bus.add(Sensed::new(node, sensor.clone()));
    bus.expect(0x701, &[0x00]);
    bus.advance(200);
    // 32767 mm/s fits 6030h.01 (1 mm/s per digit): no error.
    sensor.move_at(32_767_000);
    bus.advance(300);
    bus.expect_silence();
    assert_eq!(sdo_read(&mut bus, 1, 0x6030, 1), 32767);
    // 32768 mm/s does not: 6030h.01 saturates and FF12h is raised, once.
    sensor.move_at(32_768_000);
    bus.advance(300);
    bus.expect(0x081, &emcy(0xFF12, 0x81));
    bus.expect_silence();
    assert_eq!(sdo_read(&mut bus, 1, 0x6030, 1), 32767);
    // Slower again: cleared at the next window.
    sensor.move_at(-1_000_000);
    bus.advance(200);
    bus.expect(0x081, &emcy(0x0000, 0x00));
    bus.expect_silence();
    assert_eq!(sdo_read(&mut bus, 1, 0x6030, 1) as u16 as i16, -1000);
}

// Point 12: an expedited download without size indication (22h, CiA 301 §7.2.4.3.3: s = 0,
// "the data size is not indicated") writes the object's size from bytes 4..; a download whose
// indicated size differs from the object keeps CiA 301's 06070012h (too long) / 06070013h
// (too short). No manual's abort table lists them (SGH10 4.4.1.3, SGH50 4.4.1.3, WV5800M 5.4.1.3).

/// Sends an SDO request to node 1 and expects exactly `answer`.
#[track_caller]
fn sdo(bus: &mut Bus, request: [u8; 8], answer: [u8; 8]) {
    bus.send(Frame::std(0x601, &request));
    bus.expect(0x581, &answer);
}

#[test]
fn expedited_download_without_size_takes_the_object_size() {
    each_encoder(1, |name, bus| {
        // 1017h, UNSIGNED16: 1000 ms; bytes 6..7 are not part of the value.
        sdo(bus, [0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0xFF, 0xFF], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
        assert_eq!(sdo_read(bus, 1, 0x1017, 0), 1000, "{name}");
        // 100Dh, UNSIGNED8.
        sdo(bus, [0x22, 0x0D, 0x10, 0x00, 0x03, 0xAA, 0xBB, 0xCC], [0x60, 0x0D, 0x10, 0x00, 0, 0, 0, 0]);
        assert_eq!(sdo_read(bus, 1, 0x100D, 0), 3, "{name}");
        // 1014h, UNSIGNED32, as before.
        sdo(bus, [0x22, 0x14, 0x10, 0x00, 0x81, 0x00, 0x00, 0x80], [0x60, 0x14, 0x10, 0x00, 0, 0, 0, 0]);
        assert_eq!(sdo_read(bus, 1, 0x1014, 0), 0x8000_0081, "{name}");
        // The usual checks still answer: read-only, missing object, limits.
        sdo(bus, [0x22, 0x00, 0x10, 0x00, 0, 0, 0, 0], [0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06]);
        sdo(bus, [0x22, 0x34, 0x12, 0x00, 0, 0, 0, 0], [0x80, 0x34, 0x12, 0x00, 0x00, 0x00, 0x02, 0x06]);
        sdo(bus, [0x22, 0x17, 0x10, 0x00, 0x05, 0x00, 0, 0], [0x80, 0x17, 0x10, 0x00, 0x30, 0x00, 0x09, 0x06]);
        assert_eq!(sdo_read(bus, 1, 0x1017, 0), 1000, "{name}");
    });
}

#[test]
fn sized_downloads_of_the_wrong_length_keep_their_cia_301_aborts() {
    each_encoder(1, |name, bus| {
        // 1017h is 2 bytes: 4 bytes indicated (23h) is too long, 1 byte (2Fh) too short.
        sdo(bus, [0x23, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0], [0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06]);
        sdo(bus, [0x2F, 0x17, 0x10, 0x00, 0xE8, 0, 0, 0], [0x80, 0x17, 0x10, 0x00, 0x13, 0x00, 0x07, 0x06]);
        // Segmented with size 3 to the 2-byte 1017h: too long, at the last segment.
        sdo(bus, [0x21, 0x17, 0x10, 0x00, 0x03, 0, 0, 0], [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
        sdo(bus, [0x09, 0xE8, 0x03, 0x00, 0, 0, 0, 0], [0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06]);
        assert_eq!(sdo_read(bus, 1, 0x1017, 0), 0, "{name}: nothing written");
    });
}

// Point 13: 1005h follows its object table, "rw (writable in the Pre-Operational state only,
// see chapter 4.1)" (SGH10 4.7.2.5, SGH50 4.7.2.5, WV5800M 5.7.2.5): 08000022h in
// OPERATIONAL, as 1014h and the PDO COB-IDs already answer.

#[test]
fn sync_cob_id_is_written_in_pre_operational_only() {
    each_encoder(1, |name, bus| {
        nmt(bus, 0x01, 1);
        sdo(bus, [0x23, 0x05, 0x10, 0x00, 0x85, 0, 0, 0], [0x80, 0x05, 0x10, 0x00, 0x22, 0x00, 0x00, 0x08]);
        assert_eq!(sdo_read(bus, 1, 0x1005, 0), 0x80, "{name}: unchanged");
        // As 1014h and 1800h.01 in OPERATIONAL.
        sdo(bus, [0x23, 0x14, 0x10, 0x00, 0x81, 0, 0, 0x80], [0x80, 0x14, 0x10, 0x00, 0x22, 0x00, 0x00, 0x08]);
        sdo(bus, [0x23, 0x00, 0x18, 0x01, 0x81, 0x01, 0, 0x80], [0x80, 0x00, 0x18, 0x01, 0x22, 0x00, 0x00, 0x08]);
        // A SYNC on 80h still drives the synchronous TPDO2.
        bus.send(Frame::std(0x080, &[]));
        let tpdo2 = bus.recv().expect("TPDO2 after SYNC");
        assert_eq!(tpdo2.frame.id, od_core::CanId::Std(0x281), "{name}");
        bus.expect_silence();
        nmt(bus, 0x80, 1);
        sdo(bus, [0x23, 0x05, 0x10, 0x00, 0x85, 0, 0, 0], [0x60, 0x05, 0x10, 0x00, 0, 0, 0, 0]);
        assert_eq!(sdo_read(bus, 1, 0x1005, 0), 0x85, "{name}");
    });
}

// Point 14: after an NMT reset the EMCYs announce the conditions that still hold (D-EMCY-5),
// not the ones the reset itself removed: no stale code followed at once by its 0000h.

#[test]
fn after_a_reset_only_conditions_that_still_hold_are_announced() {
    each_encoder(1, |name, bus| {
        // Work area 1 high limit 1 (unsaved): the position is above it, FF15h.
        let before = sdo_write(bus, 1, 0x6402, 1, 4, 1);
        assert_eq!(before, [Frame::std(0x081, &emcy(0xFF15, 0x81))], "{name}");
        // 82h keeps the application parameters: the condition holds and is announced again.
        nmt(bus, 0x82, 1);
        bus.expect(0x701, &[0x00]);
        bus.expect(0x081, &emcy(0xFF15, 0x81));
        bus.expect_silence();
        // 81h reloads the stored limit: the condition is gone, nothing is announced.
        nmt(bus, 0x81, 1);
        bus.expect(0x701, &[0x00]);
        bus.advance(10);
        bus.expect_silence();
        assert_eq!(sdo_read(bus, 1, 0x1001, 0), 0, "{name}");
        // Saved, the limit survives 81h, and so does the condition.
        let before = sdo_write(bus, 1, 0x6402, 1, 4, 1);
        assert_eq!(before, [Frame::std(0x081, &emcy(0xFF15, 0x81))], "{name}");
        bus.send(Frame::std(0x601, &SAVE_ALL));
        bus.expect(0x581, &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
        nmt(bus, 0x81, 1);
        bus.expect(0x701, &[0x00]);
        bus.expect(0x081, &emcy(0xFF15, 0x81));
        bus.advance(10);
        bus.expect_silence();
    });
}
