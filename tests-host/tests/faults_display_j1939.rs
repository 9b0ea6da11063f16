//! Faults and full bus load for the AP10T display and the WV58MR (J1939), with the reactions
//! their manuals prescribe, each followed by the proof that the node works normally afterwards
//! (`faults.rs` and `bus_load.rs` do the same for the encoders):
//!
//! - error passive and back, bus-off and its recovery: EMCY 8120h with 1001h = 11h, then 0000h;
//!   8140h then 0000h after the recovery (AP10T Table 14 / D-AP-23; WV58MR §5.6's EMCY table,
//!   PGN 64616 at priority 1, once the claim stood);
//! - a babbling node on the AP10T's own identifiers at 8,000 frames a second, a SYNC flood (its
//!   TPDO2 answers every SYNC), an NMT reset storm;
//! - on the WV58MR: a flood of 8,000 Requests a second for EPOS (one answer each), of Requests
//!   for Address Claimed (one claim each), and of other CAs' traffic at full load at 250 kbit/s,
//!   while its cyclic EPOS keeps its period and CAM21 reads are answered.

use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::Wv58mr;
use od_core::j1939::node::J1939Node;
use od_core::node::{BusEvent, Output};
use od_core::storage::Loaded;
use od_core::{CanId, Frame, Instant, NmtState};
use tests_host::encoder::{download_request, upload_request};
use tests_host::invariants::{check_values, Kind, Subject};

/// Runs the node's timers up to `until`; returns the frames sent with their instants.
fn run_to(node: &mut dyn Subject, from: Instant, until: Instant) -> Vec<(Instant, Frame)> {
    let mut out = Vec::new();
    let mut now = from;
    while let Some(t) = node.next_deadline().filter(|t| *t <= until) {
        now = t.max(now);
        node.poll(now);
        out.extend(frames(node).into_iter().map(|f| (now, f)));
    }
    out
}

fn frames(node: &mut dyn Subject) -> Vec<Frame> {
    let mut v = Vec::new();
    while let Some(o) = node.next_output() {
        if let Output::Frame(f) = o {
            v.push(f);
        }
    }
    v
}

/// An AP10T at node 5 (stored), detected and booted up, heartbeat 100 ms.
fn ap10t() -> Box<dyn Subject> {
    let mut node = tests_host::invariants::boot_with_id(Kind::Ap10t, 5);
    node.poll(Instant::ZERO);
    if node.listen_only() {
        node.on_frame(&Frame::std(0, &[0x80, 0x7E]), Instant::ZERO);
    }
    node.poll(Instant::from_millis(1));
    assert!(frames(node.as_mut()).contains(&Frame::std(0x705, &[0])), "boot-up");
    node.on_frame(&Frame::std(0x605, &download_request(0x1017, 0, 2, 100)), Instant::from_millis(1));
    assert_eq!(frames(node.as_mut()), [Frame::std(0x585, &[0x60, 0x17, 0x10, 0, 0, 0, 0, 0])]);
    node
}

/// The node answers normally: 1000h read, ten heartbeats in a second at exactly 100 ms.
fn answers_normally(node: &mut dyn Subject, now: Instant) {
    node.on_frame(&Frame::std(0x605, &upload_request(0x1000, 0)), now);
    let a = frames(node);
    assert_eq!(a.len(), 1, "{a:02X?}");
    assert_eq!(a[0].payload()[..4], [0x43, 0x00, 0x10, 0x00]);
    let beats: Vec<Instant> = run_to(node, now, now.add_millis(1000))
        .into_iter()
        .filter(|(_, f)| f.id == CanId::Std(0x705))
        .map(|(t, _)| t)
        .collect();
    assert_eq!(beats.len(), 10, "{beats:?}");
    assert!(beats.windows(2).all(|w| w[1].micros_since(w[0]) == 100_000), "{beats:?}");
    check_values(node.core()).unwrap();
}

fn emcy(f: &Frame) -> Option<[u8; 8]> {
    (f.id == CanId::Std(0x85)).then_some(f.data)
}

#[test]
fn ap10t_error_passive_and_bus_off_with_their_emcys() {
    let mut node = ap10t();
    let t = Instant::from_millis(10);
    node.on_bus_event(BusEvent::ErrorPassive, t);
    let sent: Vec<_> = frames(node.as_mut()).iter().filter_map(emcy).collect();
    assert_eq!(sent, [[0x20, 0x81, 0x11, 0, 0, 0, 0, 0]]);
    assert_eq!(node.core().od.value(0x1001, 0), Some(0x11));
    node.on_bus_event(BusEvent::ErrorActive, t);
    let sent: Vec<_> = frames(node.as_mut()).iter().filter_map(emcy).collect();
    assert_eq!(sent, [[0; 8]]);
    node.on_bus_event(BusEvent::BusOff, t);
    node.on_bus_event(BusEvent::BusOffRecovered, t.add_millis(5));
    let sent: Vec<_> = frames(node.as_mut()).iter().filter_map(emcy).collect();
    assert_eq!(sent, [[0x40, 0x81, 0x11, 0, 0, 0, 0, 0], [0; 8]]);
    assert_eq!(node.core().od.value(0x1001, 0), Some(0));
    assert_eq!(node.core().od.value(0x1003, 1), Some(0x8140));
    assert_eq!(node.core().od.value(0x1003, 2), Some(0x8120));
    answers_normally(node.as_mut(), t.add_millis(10));
}

#[test]
fn ap10t_babble_sync_flood_and_reset_storm() {
    let mut node = ap10t();
    let start = Instant::from_millis(10);
    // A babbling node on the display's own identifiers, 8,000 frames a second for a second,
    // with an SDO read of 1000h every 100 ms in it: the node sends its heartbeats and the
    // answers, nothing else, and stays PRE-OPERATIONAL.
    let own = [0x185u16, 0x285, 0x585, 0x705, 0x85, 0x7E4];
    let mut answers = 0;
    let mut others = 0;
    let mut now = start;
    for k in 0..8000u64 {
        now = start.add_micros(k * 125);
        let f = if k % 800 == 0 {
            Frame::std(0x605, &upload_request(0x1000, 0))
        } else {
            Frame::std(own[k as usize % own.len()], &[k as u8; 8])
        };
        for (_, s) in run_to(node.as_mut(), now, now) {
            others += (s.id != CanId::Std(0x705)) as u32;
        }
        node.on_frame(&f, now);
        for s in frames(node.as_mut()) {
            if s.id == CanId::Std(0x585) {
                answers += 1;
            } else {
                others += 1;
            }
        }
    }
    assert_eq!((answers, others), (10, 0));
    assert_eq!(node.nmt_state(), NmtState::PreOperational);
    // SYNC flood in OPERATIONAL: 8,000 SYNC a second for a second, TPDO2 (type 1) on each.
    node.on_frame(&Frame::std(0, &[0x01, 5]), now);
    frames(node.as_mut());
    let mut tpdo2 = 0;
    for k in 0..8000u64 {
        now = now.add_micros(125);
        run_to(node.as_mut(), now, now);
        node.on_frame(&Frame::std(0x80, &[]), now);
        tpdo2 += frames(node.as_mut()).iter().filter(|f| f.id == CanId::Std(0x285)).count();
        let _ = k;
    }
    assert_eq!(tpdo2, 8000);
    // NMT reset storm: 1,000 resets 50 µs apart (node and communication, broadcast and to 5):
    // 1,000 boot-ups.
    let mut boots = 0;
    for k in 0..1000u64 {
        now = now.add_micros(50);
        let cs = if k % 2 == 0 { 0x81 } else { 0x82 };
        node.on_frame(&Frame::std(0, &[cs, if k % 3 == 0 { 0 } else { 5 }]), now);
        node.poll(now);
        boots += frames(node.as_mut()).iter().filter(|f| **f == Frame::std(0x705, &[0])).count();
    }
    assert_eq!(boots, 1000);
    assert_eq!(node.nmt_state(), NmtState::PreOperational);
    // Heartbeat 100 ms was not saved: the reset storm brought 1017h back to 0; set it again.
    node.on_frame(&Frame::std(0x605, &download_request(0x1017, 0, 2, 100)), now);
    frames(node.as_mut());
    answers_normally(node.as_mut(), now.add_millis(1));
}

// ---- the WV58MR ----

struct Wv {
    node: J1939Node<Wv58mr>,
    now: Instant,
}

const EF: u32 = 0xEF;

impl Wv {
    /// A WV58MR channel on a blank flash, its claim of EFh stood.
    fn claimed() -> Wv {
        let mut wv = Wv { node: J1939Node::boot(Wv58mr::new(Turns::Multi12), &Loaded::Blank), now: Instant::ZERO };
        wv.run(500_000);
        assert_eq!(wv.node.source_address().map(|a| a.0 as u32), Some(EF));
        wv
    }

    fn out(&mut self) -> Vec<(Instant, Frame)> {
        let mut v = Vec::new();
        while let Some(o) = self.node.next_output() {
            if let Output::Frame(f) = o {
                v.push((self.now, f));
            }
        }
        v
    }

    /// Time runs on `us`; the frames sent meanwhile.
    fn run(&mut self, us: u64) -> Vec<(Instant, Frame)> {
        let until = self.now.add_micros(us);
        let mut v = Vec::new();
        while let Some(t) = self.node.next_deadline().filter(|t| *t <= until) {
            self.now = t.max(self.now);
            self.node.poll(self.now);
            v.extend(self.out());
        }
        self.now = until;
        v
    }

    fn feed(&mut self, raw: u32, data: &[u8]) -> Vec<(Instant, Frame)> {
        self.node.on_frame(&Frame::new(CanId::Ext(raw), data), self.now);
        self.out()
    }

    fn emcys(frames: &[(Instant, Frame)]) -> Vec<[u8; 8]> {
        frames.iter().filter(|(_, f)| f.id == CanId::Ext(0x04FC_6800 | EF)).map(|(_, f)| f.data).collect()
    }

    /// Works normally: a CAM21 read of 1000h answered, EPOS every 50 ms for a second.
    fn answers_normally(&mut self) {
        let a = self.feed(0x1C06_0000 | EF << 8, &upload_request(0x1000, 0));
        assert_eq!(a.len(), 1);
        assert_eq!(a[0].1.id, CanId::Ext(0x1C05_0000 | EF));
        assert_eq!(a[0].1.payload()[..4], [0x43, 0x00, 0x10, 0x00]);
        let epos: Vec<Instant> = self
            .run(1_000_000)
            .into_iter()
            .filter(|(_, f)| f.id == CanId::Ext(0x0CFC_5F00 | EF))
            .map(|(t, _)| t)
            .collect();
        assert_eq!(epos.len(), 20, "{epos:?}");
        assert!(epos.windows(2).all(|w| w[1].micros_since(w[0]) == 50_000), "{epos:?}");
        check_values(self.node.context()).unwrap();
    }
}

#[test]
fn wv58mr_error_passive_and_bus_off_with_their_emcys() {
    let mut wv = Wv::claimed();
    let now = wv.now;
    wv.node.on_bus_event(BusEvent::ErrorPassive, now);
    assert_eq!(Wv::emcys(&wv.out()), [[0x20, 0x81, 0x11, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]]);
    assert!(wv.node.leds().red != od_core::led::LedState::Off, "red LED at error passive");
    wv.node.on_bus_event(BusEvent::ErrorActive, now);
    assert_eq!(Wv::emcys(&wv.out()), [[0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]]);
    wv.node.on_bus_event(BusEvent::BusOff, now);
    assert_eq!(wv.node.leds().red, od_core::led::LedState::On, "red LED on at bus-off");
    wv.node.on_bus_event(BusEvent::BusOffRecovered, now.add_millis(5));
    assert_eq!(
        Wv::emcys(&wv.out()),
        [[0x40, 0x81, 0x11, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF], [0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]]
    );
    assert_eq!(wv.node.leds().red, od_core::led::LedState::Off);
    assert_eq!(wv.node.context().od.value(0x1003, 1), Some(0x8140));
    wv.answers_normally();
}

#[test]
fn wv58mr_request_floods_get_one_answer_each_and_full_load_keeps_its_cycle() {
    let mut wv = Wv::claimed();
    // 8,000 Requests a second for a second, for EPOS to the global address: 8,000 EPOS answers
    // besides the cyclic ones.
    let (mut answers, mut cyclic_before) = (0, 0);
    for _ in 0..8000 {
        cyclic_before += wv.run(125).len();
        answers += wv.feed(0x18EA_FF00, &[0x5F, 0xFC, 0x00]).len();
    }
    assert_eq!(answers, 8000);
    assert_eq!(cyclic_before, 40, "EPOS and ESPD every 50 ms");
    // 8,000 Requests for Address Claimed: a claim each, the address kept.
    let mut claims = 0;
    for _ in 0..8000 {
        wv.run(125);
        let a = wv.feed(0x18EA_FF21, &[0x00, 0xEE, 0x00]);
        claims += a.iter().filter(|(_, f)| f.id == CanId::Ext(0x18EE_FF00 | EF)).count();
    }
    assert_eq!(claims, 8000);
    // Full load at 250 kbit/s (about 2,000 8-byte frames a second) of other CAs' traffic: their
    // groups, their claims of other addresses, Requests and CAM21 to other addresses, with a
    // CAM21 read to us every 10 ms. Every read answered, EPOS exactly every 50 ms.
    let start = wv.now;
    let mut epos = Vec::new();
    let (mut reads, mut answered) = (0, 0);
    for k in 0..2000u32 {
        for (t, f) in wv.run(500) {
            if f.id == CanId::Ext(0x0CFC_5F00 | EF) {
                epos.push(t);
            }
        }
        let (raw, data): (u32, [u8; 8]) = match k % 5 {
            0 => {
                reads += 1;
                (0x1C06_0000 | EF << 8, upload_request(0x6004, 0))
            }
            1 => (0x0CFC_5F80, [k as u8; 8]),
            2 => (0x18EE_FF00 | (0x81 + k % 0x60), [1, 2, 3, 4, 5, 6, 7, 0x80]),
            3 => (0x18EA_8000, [0x5F, 0xFC, 0, 0, 0, 0, 0, 0]),
            _ => (0x1C06_8000 | 0x21, upload_request(0x1000, 0)),
        };
        answered += wv.feed(raw, &data).iter().filter(|(_, f)| f.id == CanId::Ext(0x1C05_0000 | EF)).count();
    }
    assert_eq!(wv.node.source_address().map(|a| a.0 as u32), Some(EF), "the address kept");
    assert_eq!((reads, answered), (400, 400));
    assert!(wv.now.micros_since(start) == 1_000_000);
    assert!(epos.len() >= 19 && epos.windows(2).all(|w| w[1].micros_since(w[0]) == 50_000), "{epos:?}");
    wv.answers_normally();
}
