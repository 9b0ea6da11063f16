//! SGH10 NMT slave, heartbeat producer, node/life guarding and EMCY producer on the bus, byte
//! for byte and in virtual time: the master sends X, the node answers Y at T (manual §4.2,
//! §4.5, §4.7.2; digest SGH10.md 3.2, 3.3, 3.7-3.9 and 6.2), and the failure cases.
//! Decisions in docs/decisions.md, "NMT", "Heartbeat and node guarding", "EMCY and error
//! history".
//!
//! Dictionary writes go through [`Rig::download`], which applies a write exactly as the SDO
//! server's `Dict::write` does (entry checks, then the service's `on_write`, then the value)
//! and returns the abort code the server would send, until the SDO server lands.

use std::collections::VecDeque;

use proptest::prelude::*;

use od_core::emcy::{self, COMMUNICATION, MANUFACTURER};
use od_core::node::Output;
use od_core::od::{CoreHook, Hook};
use od_core::storage::{Image, Loaded, Record};
use od_core::{Abort, Bitrate, CanId, Frame, Instant, NmtState, Node};
use tests_host::TableOnly;

type Sgh10 = Node<TableOnly>;

/// Nodes and a master on one bus, in virtual time.
struct Rig {
    nodes: Vec<Sgh10>,
    now: Instant,
    rx: VecDeque<(Instant, Frame)>,
}

impl Rig {
    /// SGH10s with these node-IDs, powered on at t = 0 with factory defaults.
    fn new(ids: &[u8]) -> Rig {
        let nodes = ids.iter().map(|id| Node::new(TableOnly(od_core::devices::sgh10::TABLE), *id, Bitrate::K500));
        Rig::with(nodes.collect())
    }

    fn with(nodes: Vec<Sgh10>) -> Rig {
        let mut rig = Rig { nodes, now: Instant::ZERO, rx: VecDeque::new() };
        rig.run_due();
        rig
    }

    fn run_due(&mut self) {
        for node in &mut self.nodes {
            if node.next_deadline().is_some_and(|t| t <= self.now) {
                node.poll(self.now);
            }
            while let Some(out) = node.next_output() {
                if let Output::Frame(f) = out {
                    self.rx.push_back((self.now, f));
                }
            }
        }
    }

    /// The master sends `frame` now.
    fn send(&mut self, frame: Frame) {
        for node in &mut self.nodes {
            node.on_frame(&frame, self.now);
        }
        self.run_due();
    }

    fn nmt(&mut self, cs: u8, node: u8) {
        self.send(Frame::std(0x000, &[cs, node]));
    }

    fn rtr(&mut self, id: u16) {
        self.send(Frame::remote(CanId::Std(id), 1));
    }

    /// Moves time forward by `ms`, polling every node at each of its deadlines.
    fn advance(&mut self, ms: u64) {
        let until = self.now.add_millis(ms);
        loop {
            self.run_due();
            match self.nodes.iter().filter_map(|n| n.next_deadline()).min() {
                Some(t) if t <= self.now => panic!("deadline {t:?} stays due at {:?}", self.now),
                Some(t) if t <= until => self.now = t,
                _ => break,
            }
        }
        self.now = until;
        self.run_due();
    }

    /// The next frame is `id` `data`; returns when it was sent, in ms.
    #[track_caller]
    fn expect(&mut self, id: u16, data: &[u8]) -> u64 {
        let (at, f) = self.rx.pop_front().unwrap_or_else(|| panic!("expected {id:03X} {data:02X?}, bus silent"));
        assert_eq!((f.id, f.rtr, f.payload()), (CanId::Std(id), false, data), "at {} us", at.as_micros());
        at.as_millis()
    }

    /// The next frame is `id` `data`, sent at `ms`.
    #[track_caller]
    fn expect_at(&mut self, id: u16, data: &[u8], ms: u64) {
        assert_eq!(self.expect(id, data), ms, "{id:03X} {data:02X?}");
    }

    #[track_caller]
    fn silence(&mut self) {
        if let Some((at, f)) = self.rx.pop_front() {
            panic!("expected silence, got {f:?} at {} us", at.as_micros());
        }
    }

    /// An SDO download of `value` (the entry's size) to node `n`: the dictionary access path
    /// the SDO server's write takes, and the abort code it would answer.
    fn download(&mut self, n: usize, index: u16, sub: u8, value: u32) -> Result<(), Abort> {
        let now = self.now;
        let node = &mut self.nodes[n];
        let nmt = node.nmt_state();
        if !nmt.sdo_allowed() {
            panic!("no SDO in {nmt:?}");
        }
        let core = node.core();
        let pos = core.od.find(index, sub)?;
        let size = core.od.entry(pos).size();
        match core.od.entry(pos).hook {
            Hook::Core(CoreHook::HeartbeatTime | CoreHook::Guarding | CoreHook::EmcyCobId | CoreHook::ErrorHistory)
            | Hook::None => {}
            other => panic!("download helper does not cover {other:?}"),
        }
        node.write(index, sub, &value.to_le_bytes()[..size], now)?;
        Ok(())
    }

    /// An SDO upload from node `n`: the value, or the abort code.
    fn upload(&mut self, n: usize, index: u16, sub: u8) -> Result<u32, Abort> {
        let core = self.nodes[n].core();
        let pos = core.od.find(index, sub)?;
        core.od.check_read(pos)?;
        od_core::errors::check_read(&core.od, index, sub)?;
        Ok(core.od.get(pos))
    }

    /// The device reports error condition `code` at the current time.
    fn error(&mut self, n: usize, code: u16, bits: u8, active: bool) {
        let now = self.now;
        emcy::set_error(self.nodes[n].split().1, code, bits, active, now);
        self.run_due();
    }

    fn state(&self, n: usize) -> NmtState {
        self.nodes[n].nmt_state()
    }
}

/// Node-ID 1, booted: its boot-up consumed.
fn node1() -> Rig {
    let mut rig = Rig::new(&[1]);
    rig.expect_at(0x701, &[0x00], 0);
    rig.silence();
    rig
}

// ---------------------------------------------------------------- NMT

#[test]
fn boot_up_then_pre_operational_and_silent() {
    let mut rig = Rig::new(&[1, 5]);
    rig.expect_at(0x701, &[0x00], 0);
    rig.expect_at(0x705, &[0x00], 0);
    assert_eq!(rig.state(0), NmtState::PreOperational);
    // 1017h = 0 and no guarding: nothing more, however long.
    rig.advance(60_000);
    rig.silence();
}

#[test]
fn every_nmt_command_addressed_and_broadcast() {
    let mut rig = Rig::new(&[1, 2]);
    rig.expect(0x701, &[0]);
    rig.expect(0x702, &[0]);
    // Digest 6.2: 01 01 → node 1 OPERATIONAL; node 2 untouched.
    rig.nmt(0x01, 0x01);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::Operational, NmtState::PreOperational));
    // 01 00: every node.
    rig.nmt(0x01, 0x00);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::Operational, NmtState::Operational));
    rig.nmt(0x02, 0x01);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::Stopped, NmtState::Operational));
    rig.nmt(0x02, 0x00);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::Stopped, NmtState::Stopped));
    rig.nmt(0x80, 0x01);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::PreOperational, NmtState::Stopped));
    rig.nmt(0x80, 0x00);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::PreOperational, NmtState::PreOperational));
    // STOPPED → OPERATIONAL directly (transition 1 from STOPPED).
    rig.nmt(0x02, 0x00);
    rig.nmt(0x01, 0x02);
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::Stopped, NmtState::Operational));
    rig.silence();
    // 81h / 82h: the addressed node boots up again (in every state), then PRE-OPERATIONAL.
    rig.advance(10);
    rig.nmt(0x81, 0x01);
    rig.expect_at(0x701, &[0x00], 10);
    rig.silence();
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::PreOperational, NmtState::Operational));
    rig.nmt(0x82, 0x02);
    rig.expect_at(0x702, &[0x00], 10);
    assert_eq!(rig.state(1), NmtState::PreOperational);
    rig.nmt(0x82, 0x00);
    rig.expect(0x701, &[0x00]);
    rig.expect(0x702, &[0x00]);
    rig.nmt(0x01, 0x00);
    rig.nmt(0x81, 0x00);
    rig.expect(0x701, &[0x00]);
    rig.expect(0x702, &[0x00]);
    rig.silence();
    assert_eq!((rig.state(0), rig.state(1)), (NmtState::PreOperational, NmtState::PreOperational));
}

#[test]
fn malformed_nmt_frames_are_ignored() {
    let mut rig = node1();
    for f in [
        Frame::std(0x000, &[0x01]),
        Frame::std(0x000, &[0x01, 0x01, 0x00]),
        Frame::std(0x000, &[0x03, 0x01]),
        Frame::std(0x000, &[0x00, 0x01]),
        Frame::std(0x000, &[0x01, 0x81]),
        Frame::remote(CanId::Std(0x000), 2),
        Frame::new(CanId::Ext(0x000), &[0x01, 0x01]),
        Frame::std(0x001, &[0x01, 0x01]),
    ] {
        rig.send(f);
        assert_eq!(rig.state(0), NmtState::PreOperational, "{f:?}");
    }
    rig.silence();
}

#[test]
fn reset_node_reloads_every_group_reset_communication_only_communication() {
    let mut rig = node1();
    // Unsaved changes: heartbeat (communication) and total measuring range (application).
    rig.download(0, 0x1017, 0, 1000).unwrap();
    rig.download(0, 0x6002, 0, 5000).unwrap();
    rig.nmt(0x82, 0x01);
    rig.expect_at(0x701, &[0x00], 0);
    assert_eq!(rig.upload(0, 0x1017, 0), Ok(0));
    assert_eq!(rig.upload(0, 0x6002, 0), Ok(5000), "82h keeps the application parameters");
    rig.advance(5000);
    rig.silence();
    rig.nmt(0x81, 0x01);
    rig.expect_at(0x701, &[0x00], 5000);
    assert_eq!(rig.upload(0, 0x6002, 0), Ok(10239), "81h reloads them");
}

// ---------------------------------------------------------------- Heartbeat

#[test]
fn heartbeat_digest_6_2_in_every_state() {
    let mut rig = node1();
    rig.advance(40);
    // 601h 2B 17 10 00 64 00 00 00 → 581h 60 17 10 00 ...; then 701h 7F every 100 ms.
    assert_eq!(rig.download(0, 0x1017, 0, 100), Ok(()));
    rig.advance(99);
    rig.silence();
    rig.advance(1);
    rig.expect_at(0x701, &[0x7F], 140);
    rig.advance(100);
    rig.expect_at(0x701, &[0x7F], 240);
    rig.advance(10);
    rig.nmt(0x01, 0x01);
    rig.advance(90);
    rig.expect_at(0x701, &[0x05], 340);
    rig.nmt(0x02, 0x01);
    rig.advance(100);
    rig.expect_at(0x701, &[0x04], 440);
    rig.nmt(0x80, 0x01);
    rig.advance(100);
    rig.expect_at(0x701, &[0x7F], 540);
    rig.silence();
}

#[test]
fn heartbeat_limits_and_immediate_change() {
    let mut rig = node1();
    rig.download(0, 0x1017, 0, 100).unwrap();
    // 601h 2B 17 10 00 05 00 00 00 → 581h 80 17 10 00 30 00 09 06; the period stays 100 ms.
    for bad in [1, 5, 9] {
        assert_eq!(rig.download(0, 0x1017, 0, bad), Err(Abort(0x0609_0030)));
    }
    assert_eq!(rig.upload(0, 0x1017, 0), Ok(100));
    rig.advance(100);
    rig.expect_at(0x701, &[0x7F], 100);
    // 10 ms, the shortest period.
    rig.advance(50);
    rig.download(0, 0x1017, 0, 10).unwrap();
    rig.advance(30);
    rig.expect_at(0x701, &[0x7F], 160);
    rig.expect_at(0x701, &[0x7F], 170);
    rig.expect_at(0x701, &[0x7F], 180);
    rig.silence();
    // A longer period takes effect at the write, not after the running one.
    rig.advance(5);
    rig.download(0, 0x1017, 0, 0xFFFF).unwrap();
    rig.advance(65_534);
    rig.silence();
    rig.advance(1);
    rig.expect_at(0x701, &[0x7F], 185 + 65_535);
    // 0 switches the producer off at once.
    rig.download(0, 0x1017, 0, 0).unwrap();
    rig.advance(200_000);
    rig.silence();
}

#[test]
fn stored_heartbeat_starts_after_boot_up_and_restarts_after_reset() {
    let table = od_core::devices::sgh10::TABLE;
    let mut image = Image::new();
    let e = table.iter().find(|e| e.index == 0x1017).unwrap();
    image.set(Record::of(e, 200)).unwrap();
    let node = Node::boot(TableOnly(table), &Loaded::Image(image));
    // No pending node-ID stored: the factory node-ID 1.
    let mut rig = Rig::with(vec![node]);
    rig.expect_at(0x701, &[0x00], 0);
    rig.advance(450);
    rig.expect_at(0x701, &[0x7F], 200);
    rig.expect_at(0x701, &[0x7F], 400);
    rig.nmt(0x82, 0x01);
    rig.expect_at(0x701, &[0x00], 450);
    rig.advance(200);
    rig.expect_at(0x701, &[0x7F], 650);
    rig.silence();
}

// ---------------------------------------------------------------- Node guarding

#[test]
fn guarding_digest_6_2_toggle_in_every_state() {
    let mut rig = node1();
    assert_eq!(rig.download(0, 0x100C, 0, 100), Ok(()));
    assert_eq!(rig.download(0, 0x100D, 0, 3), Ok(()));
    rig.rtr(0x701);
    rig.expect_at(0x701, &[0x7F], 0);
    rig.advance(100);
    rig.rtr(0x701);
    rig.expect_at(0x701, &[0xFF], 100);
    rig.nmt(0x01, 0x01);
    for (t, b) in [(200, 0x05), (300, 0x85), (400, 0x05)] {
        rig.advance(100);
        rig.rtr(0x701);
        rig.expect_at(0x701, &[b], t);
    }
    rig.nmt(0x02, 0x01);
    rig.rtr(0x701);
    rig.expect(0x701, &[0x84]);
    rig.rtr(0x701);
    rig.expect(0x701, &[0x04]);
    rig.silence();
    // Reset communication: the toggle starts at 0 again.
    rig.nmt(0x01, 0x01);
    rig.rtr(0x701);
    rig.expect(0x701, &[0x85]);
    rig.nmt(0x82, 0x01);
    rig.expect(0x701, &[0x00]);
    rig.rtr(0x701);
    rig.expect(0x701, &[0x7F]);
    rig.nmt(0x81, 0x01);
    rig.expect(0x701, &[0x00]);
    rig.rtr(0x701);
    rig.expect(0x701, &[0x7F]);
    rig.silence();
}

#[test]
fn guarding_answers_without_guard_time_and_ignores_other_frames() {
    let mut rig = Rig::new(&[1, 2]);
    rig.expect(0x701, &[0]);
    rig.expect(0x702, &[0]);
    // 100Ch = 100Dh = 0 (defaults): RTRs are answered (SGH10 A17), any DLC.
    rig.send(Frame::remote(CanId::Std(0x702), 0));
    rig.expect(0x702, &[0x7F]);
    rig.send(Frame::remote(CanId::Std(0x702), 8));
    rig.expect(0x702, &[0xFF]);
    // A data frame on 700h + ID, an RTR on an extended 701h, an RTR to nobody: no answer.
    rig.send(Frame::std(0x701, &[0x00]));
    rig.send(Frame::remote(CanId::Ext(0x701), 1));
    rig.rtr(0x703);
    rig.silence();
    rig.rtr(0x701);
    rig.expect(0x701, &[0x7F]);
    rig.advance(100_000);
    rig.silence();
}

#[test]
fn life_guarding_event_without_emcy_or_state_change() {
    let mut rig = node1();
    rig.download(0, 0x100C, 0, 100).unwrap();
    rig.download(0, 0x100D, 0, 3).unwrap();
    rig.nmt(0x01, 0x01);
    // Not started before the first RTR.
    rig.advance(1000);
    assert!(!rig.nodes[0].guarding().life_guard_event());
    rig.rtr(0x701);
    rig.expect_at(0x701, &[0x05], 1000);
    rig.advance(299);
    assert!(!rig.nodes[0].guarding().life_guard_event());
    rig.advance(1);
    assert!(rig.nodes[0].guarding().life_guard_event(), "life time 300 ms passed at 1300");
    assert_eq!(rig.state(0), NmtState::Operational);
    assert_eq!(rig.upload(0, 0x1001, 0), Ok(0));
    rig.silence();
    // The next RTR ends the event and restarts the life time.
    rig.advance(700);
    rig.rtr(0x701);
    rig.expect_at(0x701, &[0x85], 2000);
    assert!(!rig.nodes[0].guarding().life_guard_event());
    for t in [2250, 2500, 2750] {
        rig.advance(250);
        rig.rtr(0x701);
        rig.expect_at(0x701, if t == 2500 { &[0x85] } else { &[0x05] }, t);
    }
    assert!(!rig.nodes[0].guarding().life_guard_event());
    rig.silence();
}

#[test]
fn heartbeat_switches_guarding_off() {
    let mut rig = node1();
    rig.download(0, 0x100C, 0, 100).unwrap();
    rig.download(0, 0x100D, 0, 2).unwrap();
    rig.rtr(0x701);
    rig.expect(0x701, &[0x7F]);
    rig.download(0, 0x1017, 0, 500).unwrap();
    // CiA 301: one error-control protocol at a time; with 1017h ≠ 0 it is the heartbeat.
    rig.rtr(0x701);
    rig.advance(500);
    rig.expect_at(0x701, &[0x7F], 500);
    rig.silence();
    assert!(!rig.nodes[0].guarding().life_guard_event());
    rig.download(0, 0x1017, 0, 0).unwrap();
    rig.rtr(0x701);
    rig.expect(0x701, &[0xFF]);
}

// ---------------------------------------------------------------- EMCY

#[test]
fn emcy_digest_6_2_frames_and_error_register() {
    let mut rig = node1();
    rig.nmt(0x01, 0x01);
    rig.advance(10);
    // Position error work area 1: 081h 15 FF ER, ER = bit 0 + bit 7.
    rig.error(0, 0xFF15, MANUFACTURER, true);
    rig.expect_at(0x081, &[0x15, 0xFF, 0x81, 0, 0, 0, 0, 0], 10);
    // Only once per error event.
    rig.error(0, 0xFF15, MANUFACTURER, true);
    rig.silence();
    rig.advance(10);
    // CAN error passive: 20 81, ER bit 4 set as well.
    rig.error(0, 0x8120, COMMUNICATION, true);
    rig.expect_at(0x081, &[0x20, 0x81, 0x91, 0, 0, 0, 0, 0], 20);
    assert_eq!(rig.upload(0, 0x1001, 0), Ok(0x91));
    // One cause removed: 0000h, ER still shows the other.
    rig.error(0, 0xFF15, MANUFACTURER, false);
    rig.expect(0x081, &[0x00, 0x00, 0x11, 0, 0, 0, 0, 0]);
    rig.error(0, 0x8120, COMMUNICATION, false);
    rig.expect(0x081, &[0x00, 0x00, 0x00, 0, 0, 0, 0, 0]);
    // Recovered from bus-off.
    rig.error(0, 0x8140, COMMUNICATION, true);
    rig.expect(0x081, &[0x40, 0x81, 0x11, 0, 0, 0, 0, 0]);
    rig.silence();
    // History: newest at sub 1.
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(3));
    assert_eq!(rig.upload(0, 0x1003, 1), Ok(0x8140));
    assert_eq!(rig.upload(0, 0x1003, 2), Ok(0x8120));
    assert_eq!(rig.upload(0, 0x1003, 3), Ok(0xFF15));
    assert_eq!(rig.upload(0, 0x1003, 4), Err(Abort(0x0800_0024)));
    assert_eq!(rig.upload(0, 0x1003, 9), Err(Abort(0x0609_0011)));
}

#[test]
fn emcy_state_rules() {
    let mut rig = node1();
    // PRE-OPERATIONAL: sent.
    rig.error(0, 0xFF05, MANUFACTURER, true);
    rig.expect(0x081, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    // STOPPED: nothing on the bus, 1001h/1003h still record it; not sent later either.
    rig.nmt(0x02, 0x01);
    rig.error(0, 0xFF16, MANUFACTURER, true);
    rig.error(0, 0xFF05, MANUFACTURER, false);
    rig.silence();
    assert_eq!(rig.nodes[0].core().od.value(0x1001, 0), Some(0x81));
    assert_eq!(rig.nodes[0].core().od.value(0x1003, 1), Some(0xFF16));
    rig.nmt(0x80, 0x01);
    rig.advance(1000);
    rig.silence();
    rig.nmt(0x01, 0x01);
    rig.error(0, 0xFF16, MANUFACTURER, false);
    rig.expect(0x081, &[0x00, 0x00, 0x00, 0, 0, 0, 0, 0]);
    rig.silence();
}

#[test]
fn active_conditions_are_announced_again_after_a_reset() {
    let mut rig = node1();
    rig.advance(5);
    rig.error(0, 0xFF12, MANUFACTURER, true);
    rig.expect(0x081, &[0x12, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    rig.nmt(0x82, 0x00);
    rig.expect_at(0x701, &[0x00], 5);
    rig.expect_at(0x081, &[0x12, 0xFF, 0x81, 0, 0, 0, 0, 0], 5);
    rig.silence();
    // The history is a log: the re-announcement adds no entry.
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(1));
    rig.error(0, 0xFF12, MANUFACTURER, false);
    rig.expect(0x081, &[0x00, 0x00, 0x00, 0, 0, 0, 0, 0]);
    rig.nmt(0x81, 0x00);
    rig.expect(0x701, &[0x00]);
    rig.silence();
}

#[test]
fn error_history_clear_and_refusals() {
    let mut rig = node1();
    rig.error(0, 0xFF05, MANUFACTURER, true);
    rig.error(0, 0xFF05, MANUFACTURER, false);
    rig.rx.clear();
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(1));
    // Only 0 may be written to sub 0; the entries are read-only.
    assert_eq!(rig.download(0, 0x1003, 0, 1), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1003, 0, 8), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1003, 1, 0), Err(Abort(0x0601_0002)));
    assert_eq!(rig.upload(0, 0x1003, 1), Ok(0xFF05));
    assert_eq!(rig.download(0, 0x1003, 0, 0), Ok(()));
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(0));
    assert_eq!(rig.upload(0, 0x1003, 1), Err(Abort(0x0800_0024)));
    // Ten errors: the newest eight stay.
    for n in 0..10 {
        rig.error(0, 0xFF00 + n, MANUFACTURER, true);
    }
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(8));
    assert_eq!(rig.upload(0, 0x1003, 1), Ok(0xFF09));
    assert_eq!(rig.upload(0, 0x1003, 8), Ok(0xFF02));
}

#[test]
fn emcy_cob_id_rules() {
    let mut rig = node1();
    // Changing a valid COB-ID: first invalidate (bit 31).
    assert_eq!(rig.download(0, 0x1014, 0, 0x90), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1014, 0, 0x8000_0081), Ok(()));
    rig.error(0, 0xFF05, MANUFACTURER, true);
    rig.silence();
    // Bit 30, 11-bit with bits 28..11, restricted identifiers: refused.
    assert_eq!(rig.download(0, 0x1014, 0, 0xC000_0090), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1014, 0, 0x0000_0890), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1014, 0, 0x0000_0701), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1014, 0, 0x0000_0000), Err(Abort(0x0609_0030)));
    assert_eq!(rig.download(0, 0x1014, 0, 0x8000_0090), Ok(()));
    assert_eq!(rig.download(0, 0x1014, 0, 0x0000_0090), Ok(()));
    rig.error(0, 0xFF05, MANUFACTURER, false);
    rig.expect(0x090, &[0x00, 0x00, 0x00, 0, 0, 0, 0, 0]);
    // 29-bit identifier.
    rig.download(0, 0x1014, 0, 0x8000_0090).unwrap();
    rig.download(0, 0x1014, 0, 0x2012_3456).unwrap();
    rig.error(0, 0xFF05, MANUFACTURER, true);
    let (_, f) = rig.rx.pop_front().unwrap();
    assert_eq!((f.id, f.payload()), (CanId::Ext(0x0012_3456), &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0][..]));
    // OPERATIONAL: 1014h is not writable (manual 4.7.2.13).
    rig.nmt(0x01, 0x01);
    assert_eq!(rig.download(0, 0x1014, 0, 0xA012_3456), Err(Abort(0x0800_0022)));
    // Reset communication without a save: 80h + node-ID again.
    rig.nmt(0x82, 0x01);
    rig.expect(0x701, &[0x00]);
    rig.expect(0x081, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    rig.silence();
}

#[test]
fn emcy_follows_the_node_id() {
    let mut rig = Rig::new(&[0x7F]);
    rig.expect(0x77F, &[0x00]);
    rig.error(0, 0xFF05, MANUFACTURER, true);
    rig.expect(0x0FF, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0]);
}

#[test]
fn stored_history_is_there_after_power_on() {
    let table = od_core::devices::sgh10::TABLE;
    let mut image = Image::new();
    for (sub, v) in [(0u8, 2u32), (1, 0xFF16), (2, 0x8120)] {
        let e = table.iter().find(|e| e.index == 0x1003 && e.sub == sub).unwrap();
        image.set(Record::of(e, v)).unwrap();
    }
    let mut rig = Rig::with(vec![Node::boot(TableOnly(table), &Loaded::Image(image))]);
    rig.expect(0x701, &[0x00]);
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(2));
    assert_eq!(rig.upload(0, 0x1003, 2), Ok(0x8120));
    assert_eq!(rig.upload(0, 0x1003, 3), Err(Abort(0x0800_0024)));
    // A new error goes on top of the stored ones; the error register starts clear.
    assert_eq!(rig.upload(0, 0x1001, 0), Ok(0));
    rig.error(0, 0xFF05, MANUFACTURER, true);
    rig.expect(0x081, &[0x05, 0xFF, 0x81, 0, 0, 0, 0, 0]);
    assert_eq!(rig.upload(0, 0x1003, 0), Ok(3));
    assert_eq!(rig.upload(0, 0x1003, 3), Ok(0x8120));
}

// ---------------------------------------------------------------- Model check

/// Identifiers of services outside this model: SYNC and the TPDO remote requests (PDOs),
/// SDO requests, LSS.
fn other_service(id: u16) -> bool {
    matches!(id, 0x080 | 0x180..=0x2FF | 0x600..=0x67F | 0x7E5)
}

/// A frame a master or another node might put on the bus near the NMT/guarding identifiers.
fn any_frame() -> impl Strategy<Value = Frame> {
    let other = (0u16..0x800).prop_filter("another service", |id| !other_service(*id));
    let id = prop_oneof![Just(0x000u16), Just(0x701), Just(0x702), Just(0x081), other];
    (id, any::<bool>(), proptest::collection::vec(any::<u8>(), 0..=8), any::<bool>()).prop_map(
        |(id, rtr, data, nmt_like)| {
            if rtr {
                Frame::remote(CanId::Std(id), data.len() as u8)
            } else if nmt_like && id == 0 {
                // Mostly well-formed NMT commands, to node 1, 2 or everyone.
                let cs = [0x01, 0x02, 0x80, 0x81, 0x82][data.first().copied().unwrap_or(0) as usize % 5];
                Frame::std(0, &[cs, data.get(1).copied().unwrap_or(0) % 3])
            } else {
                Frame::std(id, &data)
            }
        },
    )
}

proptest! {
    /// Any sequence of frames: the node follows the CiA 301 NMT state machine, answers every
    /// guarding RTR with its state and the alternating toggle, boots up after each reset, and
    /// sends nothing else (no heartbeat configured, no errors).
    #[test]
    fn nmt_and_guarding_follow_the_model(frames in proptest::collection::vec(any_frame(), 1..60)) {
        let mut rig = node1();
        let mut state = NmtState::PreOperational;
        let mut toggle = false;
        for f in frames {
            rig.send(f);
            if f.id == CanId::Std(0) && !f.rtr && f.len == 2 && (f.data[1] == 0 || f.data[1] == 1) {
                match f.data[0] {
                    0x01 => state = NmtState::Operational,
                    0x02 => state = NmtState::Stopped,
                    0x80 => state = NmtState::PreOperational,
                    0x81 | 0x82 => {
                        rig.expect(0x701, &[0x00]);
                        state = NmtState::PreOperational;
                        toggle = false;
                    }
                    _ => {}
                }
            }
            if f.id == CanId::Std(0x701) && f.rtr {
                rig.expect(0x701, &[(toggle as u8) << 7 | state.code()]);
                toggle = !toggle;
            }
            prop_assert_eq!(rig.state(0), state);
            rig.silence();
        }
    }
}
