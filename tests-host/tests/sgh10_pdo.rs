//! SYNC and PDOs on the virtual bus: the SGH10's two TPDOs (manual §4.3.1, objects 1005h,
//! 1800h/1801h, 1A00h/1A01h, 6200h; digest `SGH10.md` 3.4, 3.5 and the TPDO and COB-ID vectors
//! of 6.2) byte for byte and in virtual time, and receive PDOs on a small test dictionary laid
//! out like the AP10T's (two RPDOs, static mapping, RTR on an RPDO answered by the device).
//!
//! Configuration goes through SDO frames as a master sends them. The test station answers
//! expedited SDO requests itself through the node's dictionary access path (`Shim`), so that
//! it can poke measurements in between.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use od_core::abort::Abort;
use od_core::devices::sgh10;
use od_core::node::{BusEvent, CanopenDevice, Context, Core, Device, Link, Node, Output, RxIds};
use od_core::od::{Access::*, CoreHook::*, DataType::*, Entry, Hook};
use od_core::pdo::RtrReply;
use od_core::{Bitrate, CanId, Frame, Instant, RxId};
use tests_host::bus::{Bus, Station};

// ---------------------------------------------------------------------------------------------
// Test station

/// Values the test puts into the dictionary (the encoder's measurements, for example), applied
/// before the node sees its next frame or timer.
type Pokes = Rc<RefCell<VecDeque<(u16, u8, u32)>>>;

/// A node on the bus that also answers expedited SDO requests (download 23h/27h/2Bh/2Fh,
/// upload 40h) through the dictionary checks and the write hooks, until the SDO server lands.
struct Shim<D: CanopenDevice> {
    node: Node<D>,
    pokes: Pokes,
    sdo: VecDeque<Frame>,
}

impl<D: CanopenDevice> Shim<D> {
    fn new(node: Node<D>) -> (Shim<D>, Pokes) {
        let pokes = Pokes::default();
        (Shim { node, pokes: pokes.clone(), sdo: VecDeque::new() }, pokes)
    }

    fn apply_pokes(&mut self) {
        let core = self.node.split().1;
        while let Some((index, sub, value)) = self.pokes.borrow_mut().pop_front() {
            assert!(core.od.set_value(index, sub, value), "{index:04X}.{sub} declared");
        }
    }

    fn sdo(&mut self, req: &[u8], now: Instant) -> [u8; 8] {
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        let mut answer = [0, req[1], req[2], sub, 0, 0, 0, 0];
        let result = match req[0] {
            0x23 | 0x27 | 0x2B | 0x2F => {
                let n = 4 - ((req[0] >> 2) & 3) as usize;
                self.node.write(index, sub, &req[4..4 + n], now).map(|_| {
                    answer[0] = 0x60;
                })
            }
            0x40 => self.node.core().od.find(index, sub).and_then(|pos| {
                let core = self.node.core();
                core.od.check_read(pos)?;
                let n = core.od.encode(pos, &mut answer[4..]);
                answer[0] = 0x43 | (((4 - n) as u8) << 2);
                Ok(())
            }),
            _ => Err(Abort::INVALID_COMMAND),
        };
        if let Err(abort) = result {
            answer[0] = 0x80;
            answer[4..].copy_from_slice(&abort.0.to_le_bytes());
        }
        answer
    }
}

impl<D: CanopenDevice> od_core::Station for Shim<D> {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.apply_pokes();
        let core = self.node.core();
        let sdo_rx = CanId::Std(0x600 + core.node_id as u16);
        if frame.id == sdo_rx && !frame.rtr && frame.len == 8 && self.node.nmt_state().sdo_allowed() {
            let answer = self.sdo(frame.payload(), now);
            self.sdo.push_back(Frame::std(0x580 + self.node.core().node_id as u16, &answer));
            return;
        }
        self.node.on_frame(frame, now);
    }
    fn poll(&mut self, now: Instant) {
        self.apply_pokes();
        self.node.poll(now);
    }
    fn next_deadline(&self) -> Option<Instant> {
        self.node.next_deadline()
    }
    fn next_output(&mut self) -> Option<Output> {
        self.sdo.pop_front().map(Output::Frame).or_else(|| self.node.next_output())
    }
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.node.store_done(result, now)
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.node.on_bus_event(event, now)
    }
    fn rx_ids(&self) -> RxIds {
        self.node.rx_ids()
    }
    fn rx_ids_generation(&self) -> u32 {
        self.node.rx_ids_generation()
    }
    fn context(&self) -> &Context {
        self.node.context()
    }
}

impl<D: CanopenDevice> Station for Shim<D> {}

// ---------------------------------------------------------------------------------------------
// SGH10

/// The SGH10 dictionary with the manual's one PDO-related device rule: 6200h and 1800h.05 are
/// one value ("permanently internally linked"): a link to TPDO1's event timer, whichever of
/// the two carries the device hook, and the device keeps the two entries equal.
struct Sgh10Pdo;

impl Device for Sgh10Pdo {
    fn table(&self) -> &'static [Entry] {
        sgh10::TABLE
    }

    fn link(&self, e: &Entry) -> Option<Link> {
        matches!((e.index, e.sub), (0x6200, 0) | (0x1800, 5)).then_some(Link {
            index: 0x1800,
            sub: 5,
            hook: PdoEventTimer,
        })
    }

    fn on_write(&mut self, core: &mut Core, pos: usize, value: u32, _now: Instant) -> Result<(), Abort> {
        let e = core.od.entry(pos);
        if matches!((e.index, e.sub), (0x6200, 0) | (0x1800, 5)) {
            core.od.set_value(0x6200, 0, value);
        }
        Ok(())
    }
}

impl CanopenDevice for Sgh10Pdo {}

/// Position 510 (0.1 mm) and velocity 0, as in the digest's TPDO vectors.
const POS_510: [u8; 6] = [0xFE, 0x01, 0x00, 0x00, 0x00, 0x00];

fn sgh10() -> (Bus, Pokes) {
    let mut bus = Bus::new();
    let (shim, pokes) = Shim::new(Node::new(Sgh10Pdo, 1, Bitrate::K500));
    bus.add(shim);
    bus.expect(0x701, &[0x00]);
    pokes.borrow_mut().push_back((0x6020, 1, 510));
    (bus, pokes)
}

fn sdo_ok(bus: &mut Bus, req: [u8; 8]) {
    bus.send(Frame::std(0x601, &req));
    bus.expect(0x581, &[0x60, req[1], req[2], req[3], 0, 0, 0, 0]);
}

fn sdo_abort(bus: &mut Bus, req: [u8; 8], abort: u32) {
    bus.send(Frame::std(0x601, &req));
    let a = abort.to_le_bytes();
    bus.expect(0x581, &[0x80, req[1], req[2], req[3], a[0], a[1], a[2], a[3]]);
}

fn start(bus: &mut Bus) {
    bus.send(Frame::std(0x000, &[0x01, 0x01]));
}

fn sync(bus: &mut Bus) {
    bus.send(Frame::std(0x080, &[]));
}

fn rtr(bus: &mut Bus, id: u16) {
    bus.send(Frame::remote(CanId::Std(id), 6));
}

#[test]
fn digest_tpdo_vectors() {
    // Digest 6.2 "TPDOs": 1800h.05 = 100 ms, TPDO1 every 100 ms, TPDO2 on SYNC, RTR on 181h.
    let (mut bus, pokes) = sgh10();
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x64, 0x00, 0x00, 0x00]);
    start(&mut bus);
    let t0 = bus.now();
    for k in 1..=3 {
        bus.advance(100);
        assert_eq!(bus.expect(0x181, &POS_510).at, t0.add_millis(100 * k));
    }
    sync(&mut bus);
    bus.expect(0x281, &POS_510);
    rtr(&mut bus, 0x181);
    bus.expect(0x181, &POS_510);
    rtr(&mut bus, 0x281);
    bus.expect(0x281, &POS_510);
    bus.expect_silence();
    // "Velocity −5 mm/s would be bytes 4–5 = FB FF."
    pokes.borrow_mut().push_back((0x6030, 1, (-5i16) as u16 as u32));
    sync(&mut bus);
    bus.expect(0x281, &[0xFE, 0x01, 0x00, 0x00, 0xFB, 0xFF]);
}

#[test]
fn manual_e2_cycle_timer_is_the_event_timer() {
    // Manual §4.4.1.4 E2: 6200h = 4500 ms; 1800h.05 reads the same; TPDO1 every 4.5 s.
    let (mut bus, _) = sgh10();
    sdo_ok(&mut bus, [0x2B, 0x00, 0x62, 0x00, 0x94, 0x11, 0x00, 0x00]);
    bus.send(Frame::std(0x601, &[0x40, 0x00, 0x18, 0x05, 0, 0, 0, 0]));
    bus.expect(0x581, &[0x4B, 0x00, 0x18, 0x05, 0x94, 0x11, 0x00, 0x00]);
    bus.advance(10_000);
    bus.expect_silence();
    start(&mut bus);
    let t0 = bus.now();
    bus.advance(4_499);
    bus.expect_silence();
    bus.advance(1);
    assert_eq!(bus.expect(0x181, &POS_510).at, t0.add_millis(4_500));
    bus.advance(4_500);
    assert_eq!(bus.expect(0x181, &POS_510).at, t0.add_millis(9_000));
    // 0 disables it ("The TPD01 will not be sent if the value 0 ms is written").
    sdo_ok(&mut bus, [0x2B, 0x00, 0x62, 0x00, 0x00, 0x00, 0x00, 0x00]);
    bus.advance(20_000);
    bus.expect_silence();
}

#[test]
fn event_timer_change_applies_at_the_next_timer_operation() {
    let (mut bus, _) = sgh10();
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x64, 0x00, 0x00, 0x00]);
    start(&mut bus);
    let t0 = bus.now();
    bus.advance(30);
    // 100 ms → 10 ms while running: the pending 100 ms expiry stays, then every 10 ms.
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x0A, 0x00, 0x00, 0x00]);
    bus.advance(100);
    let times: Vec<u64> = bus.drain().iter().map(|s| s.at.micros_since(t0) / 1000).collect();
    assert_eq!(times, [100, 110, 120, 130]);
}

#[test]
fn no_pdo_outside_operational() {
    let (mut bus, _) = sgh10();
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x0A, 0x00, 0x00, 0x00]);
    // PRE-OPERATIONAL: no timer, SYNC or RTR transmission.
    bus.advance(100);
    sync(&mut bus);
    rtr(&mut bus, 0x181);
    rtr(&mut bus, 0x281);
    bus.expect_silence();
    start(&mut bus);
    bus.advance(10);
    bus.expect(0x181, &POS_510);
    // STOPPED: nothing either.
    bus.send(Frame::std(0x000, &[0x02, 0x01]));
    bus.advance(100);
    sync(&mut bus);
    rtr(&mut bus, 0x181);
    bus.expect_silence();
    // Back to OPERATIONAL: the timer restarts one period later.
    start(&mut bus);
    let t = bus.now();
    bus.advance(10);
    assert_eq!(bus.expect(0x181, &POS_510).at, t.add_millis(10));
    // Reset communication: INITIALISATION, boot-up, PRE-OPERATIONAL, silence.
    bus.send(Frame::std(0x000, &[0x82, 0x01]));
    bus.expect(0x701, &[0x00]);
    bus.advance(100);
    sync(&mut bus);
    bus.expect_silence();
}

#[test]
fn tpdo2_every_nth_sync() {
    let (mut bus, _) = sgh10();
    // 1801h.02 = 3: every third SYNC counted from entering OPERATIONAL.
    sdo_ok(&mut bus, [0x2F, 0x01, 0x18, 0x02, 0x03, 0x00, 0x00, 0x00]);
    sync(&mut bus); // PRE-OPERATIONAL: not counted
    start(&mut bus);
    let mut sent = Vec::new();
    for k in 1..=10 {
        sync(&mut bus);
        if bus.recv().is_some() {
            sent.push(k);
        }
    }
    assert_eq!(sent, [3, 6, 9]);
    // Re-entering OPERATIONAL restarts the count.
    bus.send(Frame::std(0x000, &[0x80, 0x01]));
    start(&mut bus);
    sync(&mut bus);
    sync(&mut bus);
    bus.expect_silence();
    sync(&mut bus);
    bus.expect(0x281, &POS_510);
    // 240 (F0h) is the largest n; 241, 0 and the asynchronous types are refused.
    sdo_ok(&mut bus, [0x2F, 0x01, 0x18, 0x02, 0xF0, 0x00, 0x00, 0x00]);
    for t in [0xF1, 0x00, 0xFE, 0xFF] {
        sdo_abort(&mut bus, [0x2F, 0x01, 0x18, 0x02, t, 0x00, 0x00, 0x00], 0x0609_0030);
    }
    // FCh / FDh: RTR only.
    for t in [0xFC, 0xFD] {
        sdo_ok(&mut bus, [0x2F, 0x01, 0x18, 0x02, t, 0x00, 0x00, 0x00]);
        sync(&mut bus);
        bus.expect_silence();
        rtr(&mut bus, 0x281);
        bus.expect(0x281, &POS_510);
    }
}

#[test]
fn fch_sends_the_value_sampled_at_the_sync() {
    let (mut bus, pokes) = sgh10();
    sdo_ok(&mut bus, [0x2F, 0x01, 0x18, 0x02, 0xFC, 0x00, 0x00, 0x00]);
    start(&mut bus);
    sync(&mut bus);
    pokes.borrow_mut().push_back((0x6020, 1, 511));
    rtr(&mut bus, 0x281);
    bus.expect(0x281, &POS_510);
    sync(&mut bus);
    rtr(&mut bus, 0x281);
    bus.expect(0x281, &[0xFF, 0x01, 0x00, 0x00, 0x00, 0x00]);
}

#[test]
fn tpdo1_transmission_types() {
    let (mut bus, _) = sgh10();
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x0A, 0x00, 0x00, 0x00]);
    for t in [0x00, 0x01, 0xF0, 0xFC] {
        sdo_abort(&mut bus, [0x2F, 0x00, 0x18, 0x02, t, 0x00, 0x00, 0x00], 0x0609_0030);
    }
    // FFh behaves as FEh (A2): event timer.
    sdo_ok(&mut bus, [0x2F, 0x00, 0x18, 0x02, 0xFF, 0x00, 0x00, 0x00]);
    start(&mut bus);
    bus.advance(10);
    bus.expect(0x181, &POS_510);
    // FDh: RTR only, no timer, not on SYNC (TPDO2 still is).
    sdo_ok(&mut bus, [0x2F, 0x00, 0x18, 0x02, 0xFD, 0x00, 0x00, 0x00]);
    bus.advance(100);
    bus.expect_silence();
    rtr(&mut bus, 0x181);
    bus.expect(0x181, &POS_510);
    sync(&mut bus);
    bus.expect(0x281, &POS_510);
    bus.expect_silence();
    // Back to FEh: the timer starts from the write.
    sdo_ok(&mut bus, [0x2F, 0x00, 0x18, 0x02, 0xFE, 0x00, 0x00, 0x00]);
    let t = bus.now();
    bus.advance(10);
    assert_eq!(bus.expect(0x181, &POS_510).at, t.add_millis(10));
}

#[test]
fn digest_cob_id_change_of_tpdo1() {
    // Digest 6.2 "COB-ID change of TPDO1" and manual §4.1.
    let (mut bus, _) = sgh10();
    sdo_ok(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80]);
    sdo_ok(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x80]);
    sdo_ok(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x00]);
    start(&mut bus);
    rtr(&mut bus, 0x181);
    bus.expect_silence();
    rtr(&mut bus, 0x190);
    bus.expect(0x190, &POS_510);
    // "(in OPERATIONAL) 581h 80 00 18 01 22 00 00 08".
    sdo_abort(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x80], 0x0800_0022);
    sdo_abort(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x02, 0x00, 0x80], 0x0800_0022);
}

#[test]
fn cob_id_rules() {
    let (mut bus, _) = sgh10();
    // Changing a valid COB-ID without invalidating it first.
    sdo_abort(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x00], 0x0609_0030);
    // Bit 30 (RTR) may change while valid: RTR no longer answered.
    sdo_ok(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x02, 0x00, 0x40]);
    sdo_ok(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x02, 0x00, 0xC0]);
    // Restricted identifiers (CiA 301 table 70) and 29-bit are refused; invalid ones not.
    for id in [0x001u16, 0x07F, 0x101, 0x581, 0x601, 0x701, 0x7E5] {
        let [lo, hi] = id.to_le_bytes();
        sdo_abort(&mut bus, [0x23, 0x01, 0x18, 0x01, lo, hi, 0x00, 0x40], 0x0609_0030);
    }
    sdo_ok(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x01, 0x07, 0x00, 0xC0]);
    sdo_abort(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x01, 0x07, 0x00, 0x40], 0x0609_0030);
    sdo_abort(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x03, 0x00, 0x60], 0x0609_0030);
    sdo_ok(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x03, 0x00, 0x40]);
    start(&mut bus);
    sync(&mut bus);
    bus.expect(0x381, &POS_510);
    rtr(&mut bus, 0x381);
    bus.expect_silence();
    // An invalid TPDO sends nothing at all.
    bus.send(Frame::std(0x000, &[0x80, 0x01]));
    sdo_ok(&mut bus, [0x23, 0x01, 0x18, 0x01, 0x81, 0x03, 0x00, 0xC0]);
    sdo_ok(&mut bus, [0x23, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80]);
    sdo_ok(&mut bus, [0x2B, 0x00, 0x18, 0x05, 0x0A, 0x00, 0x00, 0x00]);
    start(&mut bus);
    bus.advance(100);
    sync(&mut bus);
    rtr(&mut bus, 0x181);
    bus.expect_silence();
}

#[test]
fn static_mapping_and_unsupported_parameters() {
    let (mut bus, _) = sgh10();
    // "Assignment is static and cannot be changed": 1A00h/1A01h are const/ro.
    sdo_abort(&mut bus, [0x2F, 0x00, 0x1A, 0x00, 0x00, 0x00, 0x00, 0x00], 0x0601_0002);
    sdo_abort(&mut bus, [0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60], 0x0601_0002);
    sdo_abort(&mut bus, [0x23, 0x01, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60], 0x0601_0002);
    // Inhibit time "not supported" (ro), TPDO2 event timer "not supported" (ro).
    sdo_abort(&mut bus, [0x2B, 0x00, 0x18, 0x03, 0x0A, 0x00, 0x00, 0x00], 0x0601_0002);
    sdo_abort(&mut bus, [0x2B, 0x01, 0x18, 0x03, 0x0A, 0x00, 0x00, 0x00], 0x0601_0002);
    sdo_abort(&mut bus, [0x2B, 0x01, 0x18, 0x05, 0x0A, 0x00, 0x00, 0x00], 0x0601_0002);
    // Sub 4 and 6 "not used, access attempt generates error message".
    sdo_abort(&mut bus, [0x40, 0x00, 0x18, 0x04, 0x00, 0x00, 0x00, 0x00], 0x0609_0011);
    sdo_abort(&mut bus, [0x40, 0x01, 0x18, 0x06, 0x00, 0x00, 0x00, 0x00], 0x0609_0011);
    // The mapping reads as printed.
    bus.send(Frame::std(0x601, &[0x40, 0x00, 0x1A, 0x01, 0, 0, 0, 0]));
    bus.expect(0x581, &[0x43, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60]);
    bus.send(Frame::std(0x601, &[0x40, 0x01, 0x1A, 0x02, 0, 0, 0, 0]));
    bus.expect(0x581, &[0x43, 0x01, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60]);
}

#[test]
fn sync_cob_id() {
    let (mut bus, _) = sgh10();
    // Writable in PRE-OPERATIONAL only (object table; D-PDO-9); bit 31 is not used.
    sdo_ok(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x85, 0x00, 0x00, 0x80]);
    start(&mut bus);
    sync(&mut bus);
    bus.expect_silence();
    bus.send(Frame::std(0x085, &[]));
    bus.expect(0x281, &POS_510);
    // In OPERATIONAL: 08000022h.
    sdo_abort(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x80, 0x00, 0x00, 0x00], 0x0800_0022);
    bus.send(Frame::std(0x000, &[0x80, 0x01]));
    // Bit 30 "cannot be set to 1b"; 11-bit identifiers have bits 11..28 clear; restricted.
    sdo_abort(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x80, 0x00, 0x00, 0x40], 0x0609_0030);
    sdo_abort(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x80, 0x08, 0x00, 0x00], 0x0609_0030);
    sdo_abort(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x01, 0x06, 0x00, 0x00], 0x0609_0030);
    // 29-bit SYNC (bit 29).
    sdo_ok(&mut bus, [0x23, 0x05, 0x10, 0x00, 0x80, 0x00, 0x00, 0x20]);
    start(&mut bus);
    bus.send(Frame::std(0x080, &[]));
    bus.expect_silence();
    bus.send(Frame::new(CanId::Ext(0x80), &[]));
    bus.expect(0x281, &POS_510);
    // A remote frame on the SYNC identifier is no SYNC.
    bus.send(Frame::remote(CanId::Ext(0x80), 0));
    bus.expect_silence();
    // A SYNC with a counter byte is a SYNC all the same.
    bus.send(Frame::new(CanId::Ext(0x80), &[0x07]));
    bus.expect(0x281, &POS_510);
}

#[test]
fn hardware_filter_ids() {
    let mut node = Node::new(Sgh10Pdo, 1, Bitrate::K500);
    node.poll(Instant::ZERO);
    let ids = node.rx_ids();
    let d = |id| RxId::data(CanId::Std(id));
    let r = |id| RxId::remote(CanId::Std(id));
    let want = [d(0x7E5), d(0x000), d(0x601), r(0x701), d(0x080), r(0x181), r(0x281)];
    assert_eq!(&ids[..], &want[..]);
    let g = node.rx_ids_generation();
    node.write(0x1005, 0, &0x85u32.to_le_bytes(), Instant::ZERO).unwrap();
    assert_ne!(node.rx_ids_generation(), g);
    assert!(node.rx_ids().contains(&RxId::data(CanId::Std(0x85))));
    // A new node-ID (5F0Ah.01, then reset communication) changes them too.
    let g = node.rx_ids_generation();
    node.write(0x5F0A, 1, &[5], Instant::ZERO).unwrap();
    node.on_frame(&Frame::std(0x000, &[0x82, 0x01]), Instant::ZERO);
    assert_ne!(node.rx_ids_generation(), g);
    node.poll(Instant::ZERO);
    let ids = node.rx_ids();
    assert!(ids.contains(&RxId::data(CanId::Std(0x605))) && ids.contains(&RxId::remote(CanId::Std(0x705))));
    assert!(!ids.iter().any(|r| r.id == CanId::Std(0x601)));
}

// ---------------------------------------------------------------------------------------------
// Receive PDOs: a test dictionary shaped like the AP10T's (two RPDOs, set point and control
// word, fixed mapping, a 16-bit mapping of an UNSIGNED32), its table comes with the device.

const fn hook(h: od_core::od::CoreHook) -> Hook {
    Hook::Core(h)
}

static RX: &[Entry] = &[
    Entry::var(0x1000, "Device type", Unsigned32, Ro, 0),
    Entry::var(0x1005, "COB-ID SYNC", Unsigned32, Rw, 0x80).hook(hook(SyncCobId)),
    Entry::record(0x1400, "RPDO1 communication parameter", 5, Ro),
    Entry::member(0x1400, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x200).hook(hook(PdoCobId)),
    Entry::member(0x1400, 2, "Transmission type", Unsigned8, Rw, 0xFF).hook(hook(PdoTransmissionType)),
    Entry::member(0x1400, 3, "Inhibit time", Unsigned16, Ro, 0),
    Entry::member(0x1400, 5, "Event timer", Unsigned16, Ro, 0),
    Entry::record(0x1401, "RPDO2 communication parameter", 5, Ro),
    Entry::member(0x1401, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x300).hook(hook(PdoCobId)),
    Entry::member(0x1401, 2, "Transmission type", Unsigned8, Rw, 0xFF).hook(hook(PdoTransmissionType)),
    Entry::member(0x1401, 3, "Inhibit time", Unsigned16, Ro, 0),
    Entry::member(0x1401, 5, "Event timer", Unsigned16, Ro, 0),
    Entry::record(0x1600, "RPDO1 mapping", 3, Ro),
    Entry::member(0x1600, 1, "Object 1", Unsigned32, Ro, 0x5F16_0320),
    Entry::member(0x1600, 2, "Object 2", Unsigned32, Ro, 0x5F16_0410),
    Entry::member(0x1600, 3, "Object 3", Unsigned32, Ro, 0x5F0C_0010),
    Entry::record(0x1601, "RPDO2 mapping", 3, Ro),
    Entry::member(0x1601, 1, "Object 1", Unsigned32, Ro, 0x5F16_0120),
    Entry::member(0x1601, 2, "Object 2", Unsigned32, Ro, 0x5F16_0210),
    Entry::member(0x1601, 3, "Object 3", Unsigned32, Ro, 0x5F0C_0010),
    Entry::record(0x1800, "TPDO1 communication parameter", 5, Ro),
    Entry::member(0x1800, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x180).hook(hook(PdoCobId)),
    Entry::member(0x1800, 2, "Transmission type", Unsigned8, Rw, 0xFE).hook(hook(PdoTransmissionType)),
    Entry::member(0x1800, 3, "Inhibit time", Unsigned16, Ro, 0),
    Entry::member(0x1800, 5, "Event timer", Unsigned16, Rw, 0).hook(hook(PdoEventTimer)),
    Entry::record(0x1801, "TPDO2 communication parameter", 5, Ro),
    Entry::member(0x1801, 1, "COB-ID", Unsigned32, Rw, 0).plus_node_id(0x280).hook(hook(PdoCobId)),
    Entry::member(0x1801, 2, "Transmission type", Unsigned8, Rw, 0x01).hook(hook(PdoTransmissionType)),
    Entry::member(0x1801, 3, "Inhibit time", Unsigned16, Ro, 0),
    Entry::member(0x1801, 5, "Event timer", Unsigned16, Ro, 0),
    Entry::record(0x1A00, "TPDO1 mapping", 3, Ro),
    Entry::member(0x1A00, 1, "Object 1", Unsigned32, Ro, 0x5F16_0320),
    Entry::member(0x1A00, 2, "Object 2", Unsigned32, Ro, 0x5F16_0410),
    Entry::member(0x1A00, 3, "Object 3", Unsigned32, Ro, 0x5F19_0010),
    Entry::record(0x1A01, "TPDO2 mapping", 3, Ro),
    Entry::member(0x1A01, 1, "Object 1", Unsigned32, Ro, 0x5F16_0120),
    Entry::member(0x1A01, 2, "Object 2", Unsigned32, Ro, 0x5F16_0210),
    Entry::member(0x1A01, 3, "Object 3", Unsigned32, Ro, 0x5F19_0010),
    Entry::var(0x5F0C, "Control word", Unsigned16, Ro, 0).pdo().range(0, 0xFFCC),
    Entry::array(0x5F16, "Set points", 4, Ro),
    Entry::member(0x5F16, 1, "Set point 2 (bytes 0-3)", Unsigned32, Ro, 0).pdo(),
    Entry::member(0x5F16, 2, "Set point 2 (bytes 4-5)", Unsigned32, Ro, 0).pdo(),
    Entry::member(0x5F16, 3, "Set point 1 (bytes 0-3)", Unsigned32, Ro, 0).pdo(),
    Entry::member(0x5F16, 4, "Set point 1 (bytes 4-5)", Unsigned32, Ro, 0).pdo(),
    Entry::var(0x5F19, "Status word", Unsigned16, Ro, 0).pdo(),
];

/// Receives set points; mirrors control word bit 2 into status word bit 2; answers RTR on an
/// RPDO with the TPDO of the same number, status word bit 9 set in that answer only (as the
/// AP10T's "data identifier ... only supplied when reading out the set points (RTR)").
#[derive(Default)]
struct Display {
    log: Rc<RefCell<Vec<String>>>,
}

impl Device for Display {
    fn table(&self) -> &'static [Entry] {
        RX
    }
}

impl CanopenDevice for Display {
    fn on_rpdo(&mut self, core: &mut Core, n: u8, _now: Instant) {
        let cw = core.od.value(0x5F0C, 0).unwrap();
        core.od.set_value(0x5F19, 0, cw & 0x0004);
        self.log.borrow_mut().push(format!("rpdo{n}"));
    }

    fn on_rpdo_rtr(&mut self, core: &mut Core, n: u8, reply: &RtrReply, _now: Instant) {
        let sw = core.od.value(0x5F19, 0).unwrap();
        core.od.set_value(0x5F19, 0, sw | 0x0200);
        reply.send(core, n);
        core.od.set_value(0x5F19, 0, sw);
        self.log.borrow_mut().push(format!("rtr{n}"));
    }

    fn on_sync(&mut self, _core: &mut Core, _now: Instant) {
        self.log.borrow_mut().push("sync".into());
    }
}

fn display() -> (Bus, Rc<RefCell<Vec<String>>>) {
    let device = Display::default();
    let log = device.log.clone();
    let mut bus = Bus::new();
    bus.add(Shim::new(Node::new(device, 0x7D, Bitrate::K500)).0);
    bus.expect(0x77D, &[0x00]);
    (bus, log)
}

#[test]
fn rpdo_writes_the_mapped_entries_and_tells_the_device() {
    let (mut bus, log) = display();
    // PRE-OPERATIONAL: not processed.
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    assert!(log.borrow().is_empty());
    bus.send(Frame::std(0x000, &[0x01, 0x7D]));
    // AP10T digest D20: SP1 = 12345, CW = 0004h.
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    assert_eq!(*log.borrow(), ["rpdo0"]);
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
    // D25: RPDO2, SP2 = -5, 16-bit mapping of an UNSIGNED32 takes bytes 4-5.
    bus.send(Frame::std(0x37D, &[0xFB, 0xFF, 0xFF, 0xFF, 0x41, 0x42, 0x04, 0x02]));
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0xFB, 0xFF, 0xFF, 0xFF, 0x41, 0x42, 0x04, 0x00]);
    assert_eq!(*log.borrow(), ["rpdo0", "rpdo1", "sync"]);
    // Too short (7 of 8 bytes): not processed. A control word outside its limits: discarded.
    bus.send(Frame::std(0x27D, &[0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04]));
    bus.send(Frame::std(0x27D, &[0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0xFF, 0xFF]));
    assert_eq!(log.borrow().len(), 3);
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
}

#[test]
fn rtr_on_an_rpdo_is_answered_by_the_device() {
    let (mut bus, log) = display();
    bus.send(Frame::remote(CanId::Std(0x27D), 8));
    bus.expect_silence();
    bus.send(Frame::std(0x000, &[0x01, 0x7D]));
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    bus.send(Frame::remote(CanId::Std(0x27D), 8));
    // Answered on the RPDO's identifier, status word bit 9 in this answer only.
    bus.expect(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x02]);
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
    assert_eq!(*log.borrow(), ["rpdo0", "rtr0"]);
}

#[test]
fn synchronous_rpdo_waits_for_the_sync() {
    let (mut bus, log) = display();
    bus.send(Frame::std(0x67D, &[0x2F, 0x00, 0x14, 0x02, 0x00, 0x00, 0x00, 0x00]));
    bus.expect(0x5FD, &[0x60, 0x00, 0x14, 0x02, 0x00, 0x00, 0x00, 0x00]);
    for t in [0xF1, 0xFC, 0xFD] {
        bus.send(Frame::std(0x67D, &[0x2F, 0x00, 0x14, 0x02, t, 0x00, 0x00, 0x00]));
        bus.expect(0x5FD, &[0x80, 0x00, 0x14, 0x02, 0x30, 0x00, 0x09, 0x06]);
    }
    bus.send(Frame::std(0x000, &[0x01, 0x7D]));
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    assert!(log.borrow().is_empty());
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0; 8]);
    bus.send(Frame::std(0x080, &[]));
    bus.expect(0x2FD, &[0; 8]);
    assert_eq!(*log.borrow(), ["rpdo0", "sync"]);
    bus.send(Frame::remote(CanId::Std(0x1FD), 8));
    bus.expect(0x1FD, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
}

#[test]
fn rpdo_cob_id_rules() {
    let (mut bus, log) = display();
    let sdo = |bus: &mut Bus, d: [u8; 8], answer: [u8; 8]| {
        bus.send(Frame::std(0x67D, &d));
        bus.expect(0x5FD, &answer);
    };
    // Valid: no identifier change; invalidate, change, re-validate.
    sdo(&mut bus, [0x23, 0x00, 0x14, 0x01, 0x10, 0x02, 0, 0], [0x80, 0x00, 0x14, 0x01, 0x30, 0x00, 0x09, 0x06]);
    sdo(&mut bus, [0x23, 0x00, 0x14, 0x01, 0x7D, 0x02, 0, 0x80], [0x60, 0x00, 0x14, 0x01, 0, 0, 0, 0]);
    sdo(&mut bus, [0x23, 0x00, 0x14, 0x01, 0x10, 0x02, 0, 0], [0x60, 0x00, 0x14, 0x01, 0, 0, 0, 0]);
    bus.send(Frame::std(0x000, &[0x01, 0x7D]));
    bus.send(Frame::std(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    assert!(log.borrow().is_empty());
    bus.send(Frame::std(0x210, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    assert_eq!(*log.borrow(), ["rpdo0"]);
    sdo(&mut bus, [0x23, 0x00, 0x14, 0x01, 0x10, 0x02, 0, 0x80], [0x80, 0x00, 0x14, 0x01, 0x22, 0x00, 0x00, 0x08]);
}
