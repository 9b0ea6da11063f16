//! Unit tests of the PDO layer on a small generic dictionary: one asynchronous TPDO with a
//! writable mapping, one synchronous TPDO with a fixed one, two RPDOs.

use super::*;
use crate::bitrate::Bitrate;
use crate::context::Output;
use crate::device::{CanopenDevice, Device};
use crate::node::Node;
use crate::od::{Access::*, CoreHook::*, DataType::*, Entry, Group, Hook};
use crate::storage::{self, Loaded};

const fn core(h: CoreHook) -> Hook {
    Hook::Core(h)
}

/// A writable mapping record head: `highest` objects, `count` of them mapped by default.
const fn mapping(index: u16, name: &'static str, highest: u8, count: u32) -> Entry {
    Entry::record(index, name, highest, Rw).with_default(count).hook(core(PdoMapping))
}

static T: &[Entry] = &[
    Entry::var(0x1000, "Device type", Unsigned32, Ro, 0),
    Entry::var(0x1005, "COB-ID SYNC", Unsigned32, Rw, 0x80).group(Group::Comm).hook(core(SyncCobId)),
    Entry::record(0x1400, "RPDO1 communication parameter", 2, Const),
    Entry::member(0x1400, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x200).hook(core(PdoCobId)),
    Entry::member(0x1400, 2, "Transmission type", Unsigned8, Rw, 0xFF).hook(core(PdoTransmissionType)),
    Entry::record(0x1401, "RPDO2 communication parameter", 2, Const),
    Entry::member(0x1401, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x300).hook(core(PdoCobId)),
    Entry::member(0x1401, 2, "Transmission type", Unsigned8, Rw, 0x01).hook(core(PdoTransmissionType)),
    mapping(0x1600, "RPDO1 mapping", 3, 3),
    Entry::member(0x1600, 1, "Object 1", Unsigned32, Rw, 0x2002_0020).hook(core(PdoMapping)),
    Entry::member(0x1600, 2, "Object 2", Unsigned32, Rw, 0x2001_0010).hook(core(PdoMapping)),
    Entry::member(0x1600, 3, "Object 3", Unsigned32, Rw, 0x2000_0008).hook(core(PdoMapping)),
    Entry::record(0x1601, "RPDO2 mapping", 2, Const),
    Entry::member(0x1601, 1, "Object 1", Unsigned32, Ro, 0x0005_0008),
    Entry::member(0x1601, 2, "Object 2", Unsigned32, Ro, 0x2004_0010),
    Entry::record(0x1800, "TPDO1 communication parameter", 5, Const),
    Entry::member(0x1800, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x180).hook(core(PdoCobId)),
    Entry::member(0x1800, 2, "Transmission type", Unsigned8, Rw, 0xFE).hook(core(PdoTransmissionType)),
    Entry::member(0x1800, 3, "Inhibit time", Unsigned16, Rw, 0),
    Entry::member(0x1800, 5, "Event timer", Unsigned16, Rw, 0).hook(core(PdoEventTimer)),
    Entry::record(0x1801, "TPDO2 communication parameter", 5, Const),
    Entry::member(0x1801, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x280).hook(core(PdoCobId)),
    Entry::member(0x1801, 2, "Transmission type", Unsigned8, Rw, 0x01).hook(core(PdoTransmissionType)),
    Entry::member(0x1801, 3, "Inhibit time", Unsigned16, Ro, 0),
    Entry::member(0x1801, 5, "Event timer", Unsigned16, Ro, 0),
    mapping(0x1A00, "TPDO1 mapping", 4, 2),
    Entry::member(0x1A00, 1, "Object 1", Unsigned32, Rw, 0x2002_0020).hook(core(PdoMapping)),
    Entry::member(0x1A00, 2, "Object 2", Unsigned32, Rw, 0x2001_0010).hook(core(PdoMapping)),
    Entry::member(0x1A00, 3, "Object 3", Unsigned32, Rw, 0).hook(core(PdoMapping)),
    Entry::member(0x1A00, 4, "Object 4", Unsigned32, Rw, 0).hook(core(PdoMapping)),
    Entry::record(0x1A01, "TPDO2 mapping", 2, Const),
    Entry::member(0x1A01, 1, "Object 1", Unsigned32, Ro, 0x2000_0008),
    Entry::member(0x1A01, 2, "Object 2", Unsigned32, Ro, 0x2002_0010),
    Entry::var(0x2000, "U8", Unsigned8, Rw, 0x11).pdo(),
    Entry::var(0x2001, "I16", Integer16, Rw, 0xFFFE).pdo().range(-100, 100),
    Entry::var(0x2002, "U32", Unsigned32, Rw, 0x4433_2211).pdo(),
    Entry::var(0x2003, "Not mappable", Unsigned32, Rw, 0),
    Entry::var(0x2004, "I32", Integer32, Rw, 0).pdo(),
];

struct Dev;
impl Device for Dev {
    fn table(&self) -> &'static [Entry] {
        T
    }
}
impl CanopenDevice for Dev {}

/// The dictionary in a context (node-ID 5) and the PDO layer read from it: no device, no node.
fn alone() -> (Context, Pdos) {
    let (od, storage, node_id) = storage::power_on(T, &Loaded::Blank, 5);
    let ctx = Context::new(od, storage, node_id, Bitrate::K500);
    let mut p = Pdos::default();
    p.reset(&ctx.od, at(0));
    (ctx, p)
}

fn at(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

/// A node with node-ID 5, booted; OPERATIONAL if asked.
fn node(operational: bool) -> Node<Dev> {
    let mut n = Node::new(Dev, 5, Bitrate::K500);
    n.poll(at(0));
    if operational {
        n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    }
    frames(&mut n);
    n
}

fn frames(n: &mut Node<Dev>) -> std::vec::Vec<Frame> {
    let mut v = std::vec::Vec::new();
    while let Some(o) = n.next_output() {
        if let Output::Frame(f) = o {
            v.push(f);
        }
    }
    v
}

extern crate std;

/// An SDO-like write: the hook's check, then the value.
fn write(n: &mut Node<Dev>, index: u16, sub: u8, value: u32, now: Instant) -> Result<(), Abort> {
    let (ctx, nmt, pdo) = n.parts();
    let pos = ctx.od.find(index, sub)?;
    if let Hook::Core(h) = ctx.od.entry(pos).hook {
        pdo.on_write(ctx, *nmt, h, pos, value, now)?;
    }
    ctx.od.set(pos, value);
    Ok(())
}

fn sync(n: &mut Node<Dev>, now: Instant) -> std::vec::Vec<Frame> {
    n.on_frame(&Frame::std(0x80, &[]), now);
    frames(n)
}

#[test]
fn boot_reads_the_configuration() {
    let n = node(false);
    let p = n.pdos();
    assert_eq!((p.ntpdo, p.nrpdo), (2, 2));
    assert_eq!(p.sync_id(), Some(CanId::Std(0x80)));
    assert_eq!(p.tpdo[0].id, CanId::Std(0x185));
    assert!(p.tpdo[0].params.asynchronous && !p.tpdo[1].params.asynchronous);
    assert_eq!(p.tpdo[0].map.len, 6);
    assert_eq!(p.tpdo[1].map.len, 3);
    assert_eq!(p.rpdo[0].map.len, 7);
    assert_eq!(p.rpdo[1].map.len, 3, "a dummy byte and 16 bits of an INTEGER32");
}

#[test]
fn sync_sends_packed_tpdo_only_when_operational() {
    let mut n = node(false);
    assert!(sync(&mut n, at(1)).is_empty());
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(1));
    assert_eq!(sync(&mut n, at(2)), [Frame::std(0x285, &[0x11, 0x11, 0x22])]);
    n.on_frame(&Frame::std(0, &[0x02, 0x05]), at(3));
    assert!(sync(&mut n, at(4)).is_empty());
}

#[test]
fn every_nth_sync_counted_from_entering_operational() {
    let mut n = node(false);
    write(&mut n, 0x1801, 2, 3, at(0)).unwrap();
    // SYNCs in PRE-OPERATIONAL do not count.
    sync(&mut n, at(0));
    sync(&mut n, at(0));
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    let sent: std::vec::Vec<usize> = (1..=9).filter(|_| !sync(&mut n, at(1)).is_empty()).collect();
    assert_eq!(sent, [3, 6, 9]);
    // Re-entering OPERATIONAL restarts the count.
    sync(&mut n, at(2));
    n.on_frame(&Frame::std(0, &[0x80, 0x05]), at(2));
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(2));
    assert!(sync(&mut n, at(3)).is_empty());
    assert!(sync(&mut n, at(3)).is_empty());
    assert_eq!(sync(&mut n, at(3)).len(), 1);
}

#[test]
fn transmission_type_rules() {
    let mut n = node(false);
    for t in [0u32, 1, 240, 0xF1, 0xFC] {
        assert_eq!(write(&mut n, 0x1800, 2, t, at(0)), Err(Abort::INVALID_VALUE), "async {t:X}");
    }
    for t in [0xFDu32, 0xFE, 0xFF] {
        assert_eq!(write(&mut n, 0x1800, 2, t, at(0)), Ok(()), "async {t:X}");
    }
    for t in [0u32, 241, 0xFB, 0xFE, 0xFF] {
        assert_eq!(write(&mut n, 0x1801, 2, t, at(0)), Err(Abort::INVALID_VALUE), "sync {t:X}");
    }
    for t in [1u32, 240, 0xFC, 0xFD] {
        assert_eq!(write(&mut n, 0x1801, 2, t, at(0)), Ok(()), "sync {t:X}");
    }
    for t in [0xF1u32, 0xFC, 0xFD] {
        assert_eq!(write(&mut n, 0x1400, 2, t, at(0)), Err(Abort::INVALID_VALUE), "rpdo {t:X}");
    }
    for t in [0u32, 240, 0xFE, 0xFF] {
        assert_eq!(write(&mut n, 0x1400, 2, t, at(0)), Ok(()), "rpdo {t:X}");
    }
}

#[test]
fn cob_id_rules() {
    let mut n = node(false);
    // A valid PDO keeps its identifier; bit 30 may change.
    assert_eq!(write(&mut n, 0x1800, 1, 0x190, at(0)), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut n, 0x1800, 1, 0x4000_0185, at(0)), Ok(()));
    assert!(!n.pdos().tpdo[0].rtr);
    assert_eq!(write(&mut n, 0x1800, 1, 0x8000_0185, at(0)), Ok(()));
    assert_eq!(write(&mut n, 0x1800, 1, 0x8000_0190, at(0)), Ok(()));
    // 29-bit, stray bits, restricted identifiers.
    assert_eq!(write(&mut n, 0x1800, 1, 0x2000_0190, at(0)), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut n, 0x1800, 1, 0x0000_0990, at(0)), Err(Abort::INVALID_VALUE));
    for id in [0x000, 0x005, 0x585, 0x605, 0x705, 0x7E5] {
        assert_eq!(write(&mut n, 0x1800, 1, id, at(0)), Err(Abort::INVALID_VALUE), "{id:X}");
    }
    let g = n.rx_ids_generation();
    assert_eq!(write(&mut n, 0x1800, 1, 0x190, at(0)), Ok(()));
    assert_ne!(n.rx_ids_generation(), g);
    assert_eq!(n.pdos().tpdo[0].id, CanId::Std(0x190));
    // OPERATIONAL: no COB-ID change at all.
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    assert_eq!(write(&mut n, 0x1800, 1, 0x8000_0190, at(0)), Err(Abort::DEVICE_STATE));
    assert_eq!(write(&mut n, 0x1400, 1, 0x8000_0205, at(0)), Err(Abort::DEVICE_STATE));
}

#[test]
fn sync_cob_id_rules() {
    // PRE-OPERATIONAL only (D-PDO-9).
    let mut n = node(true);
    assert_eq!(write(&mut n, 0x1005, 0, 0x0000_0081, at(0)), Err(Abort::DEVICE_STATE));
    let mut n = node(false);
    assert_eq!(write(&mut n, 0x1005, 0, 0x4000_0080, at(0)), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut n, 0x1005, 0, 0x0000_0880, at(0)), Err(Abort::INVALID_VALUE));
    assert_eq!(write(&mut n, 0x1005, 0, 0x0000_0001, at(0)), Err(Abort::INVALID_VALUE));
    let g = n.rx_ids_generation();
    // Bit 31 ignored, 29-bit allowed.
    assert_eq!(write(&mut n, 0x1005, 0, 0x8000_0081, at(0)), Ok(()));
    assert_ne!(n.rx_ids_generation(), g);
    assert_eq!(n.pdos().sync_id(), Some(CanId::Std(0x81)));
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    assert!(sync(&mut n, at(1)).is_empty());
    n.on_frame(&Frame::std(0x81, &[]), at(1));
    assert_eq!(frames(&mut n).len(), 1);
    n.on_frame(&Frame::std(0, &[0x80, 0x05]), at(1));
    assert_eq!(write(&mut n, 0x1005, 0, 0x2123_4567, at(0)), Ok(()));
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(1));
    n.on_frame(&Frame::new(CanId::Ext(0x0123_4567), &[]), at(1));
    assert_eq!(frames(&mut n).len(), 1);
    assert!(n.rx_ids().contains(&RxId::data(CanId::Ext(0x0123_4567))));
}

#[test]
fn mapping_rules() {
    let mut n = node(false);
    // Valid PDO: no mapping change.
    assert_eq!(write(&mut n, 0x1A00, 0, 0, at(0)), Err(Abort::INVALID_VALUE));
    write(&mut n, 0x1800, 1, 0x8000_0185, at(0)).unwrap();
    // Objects only while sub 0 is 0.
    assert_eq!(write(&mut n, 0x1A00, 1, 0x2000_0008, at(0)), Err(Abort::INVALID_VALUE));
    write(&mut n, 0x1A00, 0, 0, at(0)).unwrap();
    assert_eq!(write(&mut n, 0x1A00, 1, 0x2003_0020, at(0)), Err(Abort::NOT_MAPPABLE));
    assert_eq!(write(&mut n, 0x1A00, 1, 0x2005_0020, at(0)), Err(Abort::NO_OBJECT));
    assert_eq!(write(&mut n, 0x1A00, 1, 0x2000_0010, at(0)), Err(Abort::NOT_MAPPABLE));
    assert_eq!(write(&mut n, 0x1A00, 1, 0x2002_0004, at(0)), Err(Abort::NOT_MAPPABLE));
    assert_eq!(write(&mut n, 0x1A00, 1, 0x0005_0008, at(0)), Err(Abort::NO_OBJECT), "dummies are RPDO only");
    write(&mut n, 0x1A00, 1, 0x2002_0020, at(0)).unwrap();
    write(&mut n, 0x1A00, 2, 0x2002_0020, at(0)).unwrap();
    write(&mut n, 0x1A00, 3, 0x2000_0008, at(0)).unwrap();
    assert_eq!(write(&mut n, 0x1A00, 0, 3, at(0)), Err(Abort::PDO_LENGTH));
    write(&mut n, 0x1A00, 2, 0x2001_0010, at(0)).unwrap();
    // An invalid mapping cannot be enabled: sub 0 past a zero object, or past the record.
    assert_eq!(write(&mut n, 0x1A00, 0, 4, at(0)), Err(Abort::NOT_MAPPABLE));
    assert_eq!(write(&mut n, 0x1A00, 0, 5, at(0)), Err(Abort::INVALID_VALUE));
    write(&mut n, 0x1A00, 0, 3, at(0)).unwrap();
    write(&mut n, 0x1800, 1, 0x185, at(0)).unwrap();
    write(&mut n, 0x1800, 2, 0xFD, at(0)).unwrap();
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    n.on_frame(&Frame::remote(CanId::Std(0x185), 7), at(0));
    assert_eq!(frames(&mut n), [Frame::std(0x185, &[0x11, 0x22, 0x33, 0x44, 0xFE, 0xFF, 0x11])]);
    assert_eq!(write(&mut n, 0x1A00, 0, 0, at(0)), Err(Abort::DEVICE_STATE));
}

#[test]
fn event_timer_timing() {
    let mut n = node(false);
    write(&mut n, 0x1800, 5, 100, at(0)).unwrap();
    assert_eq!(n.next_deadline(), None, "not before OPERATIONAL");
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(10));
    assert_eq!(n.next_deadline(), Some(at(110)));
    n.poll(at(109));
    assert!(frames(&mut n).is_empty());
    n.poll(at(110));
    assert_eq!(frames(&mut n), [Frame::std(0x185, &[0x11, 0x22, 0x33, 0x44, 0xFE, 0xFF])]);
    assert_eq!(n.next_deadline(), Some(at(210)));
    // A late poll keeps the grid.
    n.poll(at(215));
    assert_eq!(frames(&mut n).len(), 1);
    assert_eq!(n.next_deadline(), Some(at(310)));
    // A new period applies after the pending expiry.
    write(&mut n, 0x1800, 5, 30, at(250)).unwrap();
    assert_eq!(n.next_deadline(), Some(at(310)));
    n.poll(at(310));
    assert_eq!(n.next_deadline(), Some(at(340)));
    // 0 stops at once; a new period starts from the write.
    write(&mut n, 0x1800, 5, 0, at(320)).unwrap();
    assert_eq!(n.next_deadline(), None);
    write(&mut n, 0x1800, 5, 50, at(400)).unwrap();
    assert_eq!(n.next_deadline(), Some(at(450)));
    // RTR-only type: no timer.
    write(&mut n, 0x1800, 2, 0xFD, at(410)).unwrap();
    assert_eq!(n.next_deadline(), None);
    write(&mut n, 0x1800, 2, 0xFF, at(420)).unwrap();
    assert_eq!(n.next_deadline(), Some(at(470)));
    // Leaving OPERATIONAL stops it.
    n.on_frame(&Frame::std(0, &[0x80, 0x05]), at(430));
    assert_eq!(n.next_deadline(), None);
    frames(&mut n);
    n.poll(at(1000));
    assert!(frames(&mut n).is_empty());
}

#[test]
fn set_event_timer_writes_the_entry() {
    let mut n = node(true);
    let (ctx, _, pdo) = n.parts();
    pdo.set_event_timer(ctx, 0, 20, at(0)).unwrap();
    assert_eq!(ctx.od.value(0x1800, 5), Some(20));
    assert_eq!(pdo.next_deadline(), Some(at(20)));
    assert_eq!(pdo.set_event_timer(ctx, 1, 20, at(0)), Err(Abort::READ_ONLY), "TPDO2 has no writable timer");
    assert_eq!(pdo.set_event_timer(ctx, 3, 20, at(0)), Err(Abort::NO_OBJECT));
}

#[test]
fn inhibit_time_delays_event_transmissions() {
    let mut n = node(true);
    write(&mut n, 0x1800, 3, 250, at(0)).unwrap(); // 25 ms
    write(&mut n, 0x1800, 5, 10, at(0)).unwrap();
    let mut times = std::vec::Vec::new();
    let mut t = at(0);
    while t < at(80) {
        n.poll(t);
        if !frames(&mut n).is_empty() {
            times.push(t.as_millis());
        }
        t = n.next_deadline().unwrap();
    }
    assert_eq!(times, [10, 35, 60]);
}

#[test]
fn rtr_rules() {
    let mut n = node(false);
    n.on_frame(&Frame::remote(CanId::Std(0x185), 6), at(0));
    assert!(frames(&mut n).is_empty(), "PRE-OPERATIONAL");
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    n.on_frame(&Frame::remote(CanId::Std(0x185), 6), at(0));
    assert_eq!(frames(&mut n).len(), 1);
    n.on_frame(&Frame::remote(CanId::Std(0x285), 3), at(0));
    assert_eq!(frames(&mut n), [Frame::std(0x285, &[0x11, 0x11, 0x22])]);
    // Type FCh: the data sampled at the SYNC, sent on RTR only.
    write(&mut n, 0x1801, 2, 0xFC, at(0)).unwrap();
    assert!(sync(&mut n, at(0)).is_empty());
    n.split().1.od.set_value(0x2000, 0, 0x99);
    n.on_frame(&Frame::remote(CanId::Std(0x285), 3), at(0));
    assert_eq!(frames(&mut n), [Frame::std(0x285, &[0x11, 0x11, 0x22])]);
    sync(&mut n, at(0));
    n.on_frame(&Frame::remote(CanId::Std(0x285), 3), at(0));
    assert_eq!(frames(&mut n), [Frame::std(0x285, &[0x99, 0x11, 0x22])]);
    // Bit 30 forbids RTR.
    n.on_frame(&Frame::std(0, &[0x80, 0x05]), at(0));
    write(&mut n, 0x1800, 1, 0x4000_0185, at(0)).unwrap();
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    n.on_frame(&Frame::remote(CanId::Std(0x185), 6), at(0));
    assert!(frames(&mut n).is_empty());
    assert!(!n.rx_ids().contains(&RxId::remote(CanId::Std(0x185))));
    assert!(n.rx_ids().contains(&RxId::remote(CanId::Std(0x285))));
}

#[test]
fn rpdo_writes_mapped_entries_with_limits() {
    let (mut ctx, mut p) = alone();
    let c = &mut ctx;
    let data = [0x01, 0x02, 0x03, 0x04, 0x9C, 0xFF, 0x42, 0xAA];
    let pre = NmtState::PreOperational;
    assert_eq!(p.on_frame(c, pre, &Frame::std(0x205, &data), at(0)), PdoEvent::None, "PRE-OPERATIONAL");
    let op = NmtState::Operational;
    p.on_state(&c.od, op, at(0));
    assert_eq!(p.on_frame(c, op, &Frame::std(0x205, &data), at(0)), PdoEvent::Rpdo(0));
    assert_eq!(c.od.value(0x2002, 0), Some(0x0403_0201));
    assert_eq!(c.od.value(0x2001, 0), Some(0xFF9C));
    assert_eq!(c.od.value(0x2000, 0), Some(0x42));
    // Too short: ignored. -101 is below 2001h's limit: the whole RPDO is discarded.
    assert_eq!(p.on_frame(c, op, &Frame::std(0x205, &data[..6]), at(0)), PdoEvent::None);
    let bad = [0, 0, 0, 0, 0x9B, 0xFF, 0x43];
    assert_eq!(p.on_frame(c, op, &Frame::std(0x205, &bad), at(0)), PdoEvent::None);
    assert_eq!(c.od.value(0x2000, 0), Some(0x42));
    assert_eq!(c.od.value(0x2002, 0), Some(0x0403_0201));
    // RTR on an RPDO is the device's to answer.
    assert_eq!(p.on_frame(c, op, &Frame::remote(CanId::Std(0x205), 8), at(0)), PdoEvent::RpdoRtr(0));
    p.reply(c, 0, 1);
    assert_eq!(c.out.pop(), Some(Output::Frame(Frame::std(0x205, &[0x42, 0x01, 0x02]))));
}

#[test]
fn synchronous_rpdo_applies_at_the_next_sync() {
    let (mut c, mut p) = alone();
    let op = NmtState::Operational;
    p.on_state(&c.od, op, at(0));
    // Dummy byte skipped; 16 bits into an INTEGER32 are sign-extended.
    assert_eq!(p.on_frame(&mut c, op, &Frame::std(0x305, &[0x77, 0xFE, 0xFF]), at(0)), PdoEvent::None);
    assert_eq!(c.od.value(0x2004, 0), Some(0));
    assert_eq!(p.on_frame(&mut c, op, &Frame::std(0x80, &[]), at(0)), PdoEvent::Sync { rpdos: 0b10 });
    assert_eq!(c.od.value(0x2004, 0), Some(-2i32 as u32));
    assert_eq!(p.on_frame(&mut c, op, &Frame::std(0x80, &[]), at(0)), PdoEvent::Sync { rpdos: 0 });
}

#[test]
fn rx_ids_follow_the_configuration() {
    let mut n = node(false);
    let ids = n.rx_ids();
    let d = |id| RxId::data(CanId::Std(id));
    let r = |id| RxId::remote(CanId::Std(id));
    let want = [d(0x000), d(0x605), r(0x705), d(0x080), d(0x205), r(0x205), d(0x305), r(0x305), r(0x185), r(0x285)];
    assert_eq!(&ids[..], &want[..]);
    let g = n.rx_ids_generation();
    write(&mut n, 0x1400, 1, 0x8000_0205, at(0)).unwrap();
    assert_ne!(n.rx_ids_generation(), g);
    assert!(!n.rx_ids().iter().any(|r| r.id == CanId::Std(0x205)));
    let g = n.rx_ids_generation();
    n.on_frame(&Frame::std(0, &[0x82, 0x05]), at(0));
    assert_ne!(n.rx_ids_generation(), g);
}

#[test]
fn no_pdo_from_a_stopped_or_resetting_node() {
    let mut n = node(true);
    write(&mut n, 0x1800, 5, 10, at(0)).unwrap();
    n.on_frame(&Frame::std(0, &[0x02, 0x05]), at(1));
    n.poll(at(50));
    assert!(sync(&mut n, at(50)).is_empty());
    n.on_frame(&Frame::remote(CanId::Std(0x185), 6), at(50));
    assert!(frames(&mut n).is_empty());
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(60));
    n.on_frame(&Frame::std(0, &[0x81, 0x05]), at(65));
    n.poll(at(65));
    assert_eq!(frames(&mut n), [Frame::std(0x705, &[0])]);
    n.poll(at(200));
    assert!(frames(&mut n).is_empty());
}

mod model {
    use super::*;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Step {
        Frame { id: u16, rtr: bool, len: u8, data: [u8; 8] },
        Nmt(u8),
        Write { entry: usize, value: u32 },
        Advance(u16),
    }

    /// Identifiers near the ones the node uses, so that the handlers are hit often.
    fn id() -> impl Strategy<Value = u16> {
        prop_oneof![
            Just(0x080u16),
            Just(0x081),
            Just(0x185),
            Just(0x190),
            Just(0x205),
            Just(0x285),
            Just(0x305),
            0u16..0x800,
        ]
    }

    fn step() -> impl Strategy<Value = Step> {
        prop_oneof![
            4 => (id(), any::<bool>(), 0u8..=8, any::<[u8; 8]>())
                .prop_map(|(id, rtr, len, data)| Step::Frame { id, rtr, len, data }),
            2 => prop_oneof![Just(0x01u8), Just(0x02), Just(0x80), Just(0x82)].prop_map(Step::Nmt),
            3 => (0..T.len(), prop_oneof![
                    any::<u32>(),
                    0u32..0x100,
                    Just(0x8000_0185),
                    Just(0x185),
                    Just(0x8000_0190),
                    Just(0x190),
                    Just(0x2000_0008),
                    Just(0x2001_0010),
                ]).prop_map(|(entry, value)| Step::Write { entry, value }),
            2 => (0u16..300).prop_map(Step::Advance),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        /// Any sequence of frames, NMT commands and writes: no panic, no PDO outside
        /// OPERATIONAL, a deadline never left behind by a poll, and the cache equal to what a
        /// fresh read of the dictionary gives after a reset.
        #[test]
        fn pdo_layer_holds_its_invariants(steps in proptest::collection::vec(step(), 1..60)) {
            let mut n = node(false);
            let mut now = at(0);
            for s in steps {
                match s {
                    Step::Frame { id, rtr, len, data } => {
                        let f = if rtr { Frame::remote(CanId::Std(id), len) } else { Frame::std(id, &data[..len as usize]) };
                        n.on_frame(&f, now);
                    }
                    Step::Nmt(cs) => n.on_frame(&Frame::std(0, &[cs, 5]), now),
                    Step::Write { entry, value } => {
                        let e = T[entry];
                        let value = if e.dtype.size() < 4 { value & ((1 << (8 * e.dtype.size())) - 1) } else { value };
                        if e.access.writable() {
                            let _ = write(&mut n, e.index, e.sub, value, now);
                        }
                    }
                    Step::Advance(ms) => {
                        let until = now.add_millis(ms as u64);
                        while let Some(d) = n.next_deadline().filter(|d| *d <= until) {
                            now = now.max(d);
                            n.poll(now);
                            prop_assert!(n.next_deadline().is_none_or(|d| d > now));
                        }
                        now = until;
                    }
                }
                let operational = n.nmt_state() == NmtState::Operational;
                let pdos = n.pdos();
                let pdo_ids: std::vec::Vec<CanId> = pdos.tpdos().iter().map(|t| t.id)
                    .chain(pdos.rpdos().iter().map(|r| r.id)).collect();
                for f in frames(&mut n) {
                    if pdo_ids.contains(&f.id) {
                        prop_assert!(operational, "PDO {f:?} outside OPERATIONAL");
                    }
                }
                if !operational {
                    prop_assert_eq!(n.pdos().deadline, None);
                }
            }
            // The cache kept by the write rules equals a fresh resolution of the dictionary.
            let (ctx, nmt, pdo) = n.parts();
            let kept = pdo.clone();
            pdo.reset(&ctx.od, now);
            if *nmt == NmtState::Operational {
                pdo.running = true;
            }
            for (a, b) in kept.tpdos().iter().zip(pdo.tpdos()) {
                prop_assert_eq!((a.id, a.valid, a.rtr, a.ttype, a.map), (b.id, b.valid, b.rtr, b.ttype, b.map));
            }
            for (a, b) in kept.rpdos().iter().zip(pdo.rpdos()) {
                prop_assert_eq!((a.id, a.valid, a.ttype, a.map), (b.id, b.valid, b.ttype, b.map));
            }
            prop_assert_eq!(kept.sync_id(), pdo.sync_id());
        }
    }
}

/// A TPDO whose communication record has no mapping record beside it.
static NO_MAPPING: &[Entry] = &[
    Entry::var(0x1000, "Device type", Unsigned32, Ro, 0),
    Entry::var(0x1005, "COB-ID SYNC", Unsigned32, Rw, 0x80).group(Group::Comm).hook(core(SyncCobId)),
    Entry::record(0x1800, "TPDO1 communication parameter", 2, Const),
    Entry::member(0x1800, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x180).hook(core(PdoCobId)),
    Entry::member(0x1800, 2, "Transmission type", Unsigned8, Rw, 0x01).hook(core(PdoTransmissionType)),
];

/// A PDO without a mapping record maps nothing valid: it is unused (no SYNC transmission, no
/// remote answer), as a stored mapping that does not resolve.
#[test]
fn a_pdo_without_a_mapping_record_is_unused() {
    struct Bare;
    impl Device for Bare {
        fn table(&self) -> &'static [Entry] {
            NO_MAPPING
        }
    }
    impl CanopenDevice for Bare {}
    let mut n = Node::new(Bare, 5, Bitrate::K500);
    n.poll(at(0));
    n.on_frame(&Frame::std(0, &[0x01, 0x05]), at(0));
    while n.next_output().is_some() {}
    assert!(!n.pdos().tpdo[0].map.ok);
    n.on_frame(&Frame::std(0x80, &[]), at(1));
    n.on_frame(&Frame::remote(CanId::Std(0x185), 0), at(1));
    assert_eq!(n.next_output(), None, "no TPDO without a mapping");
}
