//! Full bus load in virtual time: a node of every CANopen kind (the encoders and the AP10T) on a
//! 1 Mbit/s bus that other nodes keep
//! busy all the time (a frame is always waiting; about 8,000 frames a second), among them frames
//! on the neighbours of its own identifiers, SDO requests to its neighbours, NMT commands for
//! other nodes and SYNC. The bus is modelled bit-exactly enough for timing: one frame at a
//! time, each taking its length in bit times, the lowest identifier winning arbitration among
//! the frames waiting (the node's controller offers its three oldest, as bxCAN's mailboxes).
//!
//! Checked: every SDO request to the node is answered well within the 1 s timeout (the worst
//! latency is printed), the heartbeat (50 ms) and the cyclic TPDO1 (10 ms) keep their periods
//! within 1 ms, the node's transmit queue never overflows and everything it queued reaches the
//! bus, and nothing addressed to the node goes unhandled. The receive-queue depth a firmware
//! would need if it stopped reading for a 40 ms flash erase at this load (frames that pass the
//! node's acceptance filters in any 40 ms) is printed and bounded.

use std::collections::VecDeque;

use od_core::node::Output;
use od_core::{CanId, Frame, Instant};
use tests_host::encoder::{download_request, upload_request};
use tests_host::invariants::{boot_with_id, Kind, Subject, ENCODERS};

const ID: u16 = 10;
const SECONDS: u64 = 2;

/// Bit times of a data frame with an 11-bit identifier and `len` bytes at 1 Mbit/s: 47 fixed
/// bits, the data, and the stuff bits a typical payload needs (about one in ten).
fn frame_us(f: &Frame) -> u64 {
    let n = f.len as u64;
    47 + 8 * n + (34 + 8 * n) / 10
}

/// The other nodes' traffic: always a frame waiting.
struct Others {
    k: u64,
}

impl Others {
    fn next(&mut self, now: Instant) -> Frame {
        self.k += 1;
        let k = self.k;
        let v = (k as u32).wrapping_mul(2_654_435_761).to_le_bytes();
        let data = [v[0], v[1], v[2], v[3], v[3], v[2], v[1], v[0]];
        // SYNC every 10 ms (by time), the rest cycles through neighbours of the node's ids.
        if now.as_micros() / 10_000 != now.as_micros().saturating_sub(frame_us(&Frame::std(0, &data))) / 10_000 {
            return Frame::std(0x80, &[]);
        }
        let near = [
            0x180 + ID - 1,
            0x180 + ID + 1,
            0x280 + ID + 1,
            0x200 + ID,
            0x080 + ID + 1,
            0x580 + ID - 1,
            0x600 + ID + 1,
            0x600 + ID - 1,
            0x700 + ID + 1,
            0x7E4,
            0x0F0,
            0x3FF,
        ];
        match k % 16 {
            13 => Frame::std(0, &[0x01, (ID + 1) as u8]),
            14 => Frame::std(0x600 + ID + 1, &upload_request(0x1000, 0)),
            15 => Frame::std(0x700 + ID - 1, &[0x05]),
            i => Frame::std(
                near[i as usize % near.len()],
                &data[..if k.is_multiple_of(8) { (k % 9) as usize } else { 8 }],
            ),
        }
    }
}

/// The master's SDO requests to the node: reads, writes and a segmented upload, one at a time,
/// the next 2 ms after the answer.
struct Master {
    /// The entry and value the master writes (one the device has).
    write: (u16, u8, usize, u32),
    step: u64,
    toggle: u8,
    segmented: bool,
    sent_at: Option<Instant>,
    next_at: Instant,
    answered: u64,
    worst_us: u64,
}

impl Master {
    fn request(&mut self) -> [u8; 8] {
        if self.segmented {
            let t = self.toggle;
            self.toggle ^= 0x10;
            return [0x60 | t, 0, 0, 0, 0, 0, 0, 0];
        }
        self.step += 1;
        match self.step % 4 {
            0 => upload_request(0x1000, 0),
            1 => download_request(self.write.0, self.write.1, self.write.2, self.write.3),
            2 => upload_request(0x1001, 0),
            _ => {
                self.toggle = 0;
                upload_request(0x1008, 0)
            }
        }
    }

    fn answer(&mut self, a: &[u8], now: Instant) {
        let sent = self.sent_at.take().expect("an answer without a request");
        self.worst_us = self.worst_us.max(now.micros_since(sent));
        self.answered += 1;
        assert_ne!(a[0], 0x80, "abort {a:02X?}");
        self.segmented = a[0] == 0x41 || (self.segmented && a[0] & 0xE1 == 0x00);
        self.next_at = now.add_millis(2);
    }
}

struct Figures {
    frames: u64,
    node_frames: u64,
    sdo: u64,
    sdo_worst_us: u64,
    heartbeat_dev_us: u64,
    tpdo_dev_us: u64,
    heartbeat_node_dev_us: u64,
    tpdo_node_dev_us: u64,
    tx_depth: usize,
    rx_40ms: usize,
}

fn run(kind: Kind) -> Figures {
    let mut node = boot_with_id(kind, ID as u8);
    let mut txq: VecDeque<Frame> = VecDeque::new();
    let mut queued = 0u64;
    // When the node queued each heartbeat and TPDO1 (its own timing, before arbitration).
    let mut queued_at: Vec<(CanId, Instant)> = Vec::new();
    let mut drain = |node: &mut Box<dyn Subject>, txq: &mut VecDeque<Frame>, queued: &mut u64, now: Instant| {
        while let Some(o) = node.next_output() {
            if let Output::Frame(f) = o {
                queued_at.push((f.id, now));
                txq.push_back(f);
                *queued += 1;
            }
        }
    };
    // Set-up before the load: heartbeat 50 ms, TPDO1 every 10 ms, OPERATIONAL.
    let mut now = Instant::ZERO;
    node.poll(now);
    // The AP10T detects the bus's rate first: the first frame it hears, then its boot-up.
    if node.listen_only() {
        node.on_frame(&Frame::std(0, &[0x80, 0x7E]), now);
        node.poll(now);
    }
    for req in [download_request(0x1017, 0, 2, 50), download_request(0x1800, 5, 2, 10)] {
        node.on_frame(&Frame::std(0x600 + ID, &req), now);
    }
    node.on_frame(&Frame::std(0, &[0x01, ID as u8]), now);
    drain(&mut node, &mut txq, &mut queued, now);
    txq.clear();
    queued = 0;

    let rx_ids: Vec<_> = node_rx_ids(kind);
    let mut others = Others { k: 0 };
    // The encoders' operating parameters, the AP10T's decimal places.
    let write = if kind == Kind::Ap10t { (0x5F11, 0, 1, 2) } else { (0x6000, 0, 2, 0x0004) };
    let mut master =
        Master { write, step: 0, toggle: 0, segmented: false, sent_at: None, next_at: now, answered: 0, worst_us: 0 };
    let mut beats = Vec::new();
    let mut tpdos = Vec::new();
    let mut accepted = VecDeque::new();
    let mut fig = Figures {
        frames: 0,
        node_frames: 0,
        sdo: 0,
        sdo_worst_us: 0,
        heartbeat_dev_us: 0,
        tpdo_dev_us: 0,
        heartbeat_node_dev_us: 0,
        tpdo_node_dev_us: 0,
        tx_depth: 0,
        rx_40ms: 0,
    };
    let end = Instant::from_millis(SECONDS * 1000);
    let mut pending_other = others.next(now);
    let mut pending_master: Option<Frame> = None;
    while now < end {
        if pending_master.is_none() && master.sent_at.is_none() && now >= master.next_at {
            pending_master = Some(Frame::std(0x600 + ID, &master.request()));
        }
        // Arbitration: the lowest identifier among the node's three oldest, the master's and
        // the others' next frame.
        let node_best = txq.iter().take(3).enumerate().min_by_key(|(_, f)| f.id).map(|(i, f)| (i, *f));
        let mut winner = (pending_other.id, 0u8);
        if let Some(m) = pending_master {
            winner = winner.min((m.id, 1));
        }
        if let Some((_, f)) = node_best {
            winner = winner.min((f.id, 2));
        }
        let frame = match winner.1 {
            0 => pending_other,
            1 => pending_master.expect("master frame"),
            _ => node_best.expect("node frame").1,
        };
        let done = now.add_micros(frame_us(&frame));
        // The node's timers run while the frame is on the wires.
        while let Some(t) = node.next_deadline().filter(|t| *t < done) {
            node.poll(t.max(now));
            drain(&mut node, &mut txq, &mut queued, t.max(now));
            fig.tx_depth = fig.tx_depth.max(txq.len());
        }
        now = done;
        fig.frames += 1;
        match winner.1 {
            0 => pending_other = others.next(now),
            1 => {
                pending_master = None;
                master.sent_at = Some(now);
            }
            _ => {
                let (i, _) = node_best.expect("node frame");
                txq.remove(i);
                fig.node_frames += 1;
                if frame.id == CanId::Std(0x700 + ID) {
                    beats.push(now);
                } else if frame.id == CanId::Std(0x180 + ID) {
                    tpdos.push(now);
                } else if frame.id == CanId::Std(0x580 + ID) {
                    master.answer(frame.payload(), now);
                }
            }
        }
        if winner.1 != 2 {
            if rx_ids.contains(&frame.id) {
                accepted.push_back(now);
                while accepted.front().is_some_and(|t: &Instant| now.micros_since(*t) >= 40_000) {
                    accepted.pop_front();
                }
                fig.rx_40ms = fig.rx_40ms.max(accepted.len());
            }
            node.on_frame(&frame, now);
            drain(&mut node, &mut txq, &mut queued, now);
            fig.tx_depth = fig.tx_depth.max(txq.len());
        }
    }
    assert!(txq.len() <= 3, "{}: {} frames still queued", kind.name(), txq.len());
    assert_eq!(queued, fig.node_frames + txq.len() as u64, "{}: the node's frames all went out", kind.name());
    let dev = |times: &[Instant], period: u64| {
        times.windows(2).map(|w| w[1].micros_since(w[0]).abs_diff(period)).max().unwrap_or(u64::MAX)
    };
    fig.heartbeat_dev_us = dev(&beats, 50_000);
    fig.tpdo_dev_us = dev(&tpdos, 10_000);
    let mine = |id: u16| -> Vec<Instant> {
        queued_at.iter().filter(|(i, t)| *i == CanId::Std(id) && *t > Instant::ZERO).map(|(_, t)| *t).collect()
    };
    fig.heartbeat_node_dev_us = dev(&mine(0x700 + ID), 50_000);
    fig.tpdo_node_dev_us = dev(&mine(0x180 + ID), 10_000);
    assert!(
        beats.len() as u64 >= SECONDS * 20 - 1,
        "{}: {} heartbeats, {} node frames, nmt {:?}",
        kind.name(),
        beats.len(),
        fig.node_frames,
        node.nmt_state()
    );
    assert!(tpdos.len() as u64 >= SECONDS * 100 - 1, "{}: {} TPDO1", kind.name(), tpdos.len());
    fig.sdo = master.answered;
    fig.sdo_worst_us = master.worst_us;
    fig
}

/// The identifiers the node accepts in OPERATIONAL with the load's configuration.
fn node_rx_ids(kind: Kind) -> Vec<CanId> {
    let node = boot_with_id(kind, ID as u8);
    let mut ids = vec![CanId::Std(0), CanId::Std(0x80), CanId::Std(0x600 + ID), CanId::Std(0x7E5)];
    for n in 0..4u16 {
        if let Some(v) = node.core().od.value(0x1400 + n, 1).filter(|v| v & 0x8000_0000 == 0) {
            ids.push(CanId::from_cob_id(v));
        }
    }
    ids
}

#[test]
fn every_kind_holds_full_load_at_1_mbit() {
    for &kind in ENCODERS.iter().chain([&Kind::Ap10t]) {
        let f = run(kind);
        eprintln!(
            "{}: {} frames/s on the bus ({} the node's), {} SDO answered (worst {} us), heartbeat +-{} us \
             queued / +-{} us on the bus, TPDO1 +-{} us queued / +-{} us on the bus, transmit queue <= {}, \
             {} accepted frames in the worst 40 ms",
            kind.name(),
            f.frames / SECONDS,
            f.node_frames,
            f.sdo,
            f.sdo_worst_us,
            f.heartbeat_node_dev_us,
            f.heartbeat_dev_us,
            f.tpdo_node_dev_us,
            f.tpdo_dev_us,
            f.tx_depth,
            f.rx_40ms
        );
        assert!((7500..=9500).contains(&(f.frames / SECONDS)), "{}: the bus is not full", kind.name());
        assert!(f.sdo >= 500, "{}: only {} SDO answers", kind.name(), f.sdo);
        assert!(f.sdo_worst_us < 5_000, "{}: an SDO answer took {} us", kind.name(), f.sdo_worst_us);
        // The node keeps its periods to well within 1 ms; on the wires, arbitration adds the
        // wait for the frames of higher priority in the queue (a 7xxh heartbeat loses to all).
        assert!(f.heartbeat_node_dev_us <= 1_000, "{}: heartbeat off by {} us", kind.name(), f.heartbeat_node_dev_us);
        assert!(f.tpdo_node_dev_us <= 1_000, "{}: TPDO1 off by {} us", kind.name(), f.tpdo_node_dev_us);
        assert!(f.heartbeat_dev_us <= 2_500, "{}: heartbeat off by {} us on the bus", kind.name(), f.heartbeat_dev_us);
        assert!(f.tpdo_dev_us <= 1_000, "{}: TPDO1 off by {} us", kind.name(), f.tpdo_dev_us);
        assert!(f.tx_depth < od_core::node::OUTBOX_DEPTH, "{}: transmit queue {}", kind.name(), f.tx_depth);
        assert!(f.rx_40ms <= 400, "{}: {} frames in 40 ms", kind.name(), f.rx_40ms);
    }
}
