//! The workloads of issue 14's benchmark (`cargo run --release -p tests-host --bin bench`,
//! `docs/benchmarks.md`): what one operation of each kind costs a node, measured under
//! callgrind as (instructions at N operations minus at 0) / N.
//!
//! Each workload builds a node through the public API only ([`Node::new`], then NMT start and
//! a heartbeat of 1000 ms, both as frames), runs N operations at one instant the way the
//! firmware loop would (hand in the frame or tick, take the outputs), and then checks that
//! every operation did what it should. Everything outside the measured loop costs the same
//! at every N, so it drops out of the difference.

use std::hint::black_box;

use od_core::devices::{ap10t, sgh10, sgh50, wv5800m, wv58mr};
use od_core::j1939::node::J1939Node;
use od_core::node::{CanopenDevice, Node, Output};
use od_core::storage::Loaded;
use od_core::storage::{identity, ParamFlash, Region};
use od_core::wire::j1939::{Address, CamRequest, CamResponse, Identifier, Pgn};
use od_core::{Bitrate, CanId, Frame, Instant, Station};

use crate::flash::{RamFlash, PAGE, WORD};

/// One kind of operation (issue 14).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Workload {
    /// Expedited SDO upload of 1018h sub 1 (`601: 40 18 10 01 ..`), one 581h answer.
    W1,
    /// Expedited SDO download of 1017h = 1000 (`601: 2B 17 10 00 E8 03 00 00`), its answer.
    W2,
    /// A SYNC, one 6-byte synchronous TPDO (TPDO2, 281h).
    W3,
    /// An idle 1 ms tick: `Node::poll` and `Node::next_deadline` with nothing due.
    W4,
    /// A frame for another node (602h), ignored.
    W5,
    /// A full 1010h sub 1 "save" to the RAM NorFlash, the answer included.
    W6,
}

impl Workload {
    /// Every workload, in order.
    pub const ALL: [Workload; 6] = [Workload::W1, Workload::W2, Workload::W3, Workload::W4, Workload::W5, Workload::W6];
    /// Those every CANopen device kind runs (W6 is measured on the SGH10).
    pub const W1_W5: [Workload; 5] = [Workload::W1, Workload::W2, Workload::W3, Workload::W4, Workload::W5];
    /// The AP10T's: it has no synchronous TPDO of position and speed for W3 (its TPDO carries
    /// the status word).
    pub const AP10T: [Workload; 4] = [Workload::W1, Workload::W2, Workload::W4, Workload::W5];
    /// The WV58MR's, on its J1939 node: W1 and W2 as CAM21 parameter accesses (read 1018h.01,
    /// write the speed PGN's cycle time 3000h.02), W4, W5 a CAM21 request for another address.
    /// It has no SYNC (W3) and its save (W6) is not measured yet.
    pub const J1939: [Workload; 4] = [Workload::W1, Workload::W2, Workload::W4, Workload::W5];

    /// `W1` ... `W6`.
    pub fn name(self) -> &'static str {
        match self {
            Workload::W1 => "W1",
            Workload::W2 => "W2",
            Workload::W3 => "W3",
            Workload::W4 => "W4",
            Workload::W5 => "W5",
            Workload::W6 => "W6",
        }
    }

    /// The workload named `name` (`W1`, `w1` ...).
    pub fn parse(name: &str) -> Option<Workload> {
        Workload::ALL.into_iter().find(|w| w.name().eq_ignore_ascii_case(name))
    }

    /// What it is, for the table.
    pub fn what(self) -> &'static str {
        match self {
            Workload::W1 => "expedited SDO upload 1018h.01 (`601: 40 18 10 01 ..` -> one 581h answer)",
            Workload::W2 => "expedited SDO download 1017h (`601: 2B 17 10 00 E8 03 00 00` -> answer)",
            Workload::W3 => "SYNC -> one 6-byte synchronous TPDO",
            Workload::W4 => "idle 1 ms tick, `poll` + `next_deadline`",
            Workload::W5 => "a frame for another node (602h), ignored",
            Workload::W6 => "1010h.01 \"save\" to the RAM NorFlash, answer included",
        }
    }

    /// Issue 14's goal: fewer instructions per operation than this.
    pub fn goal(self) -> u64 {
        match self {
            Workload::W1 | Workload::W2 => 300,
            Workload::W3 => 150,
            Workload::W4 => 60,
            Workload::W5 => 30,
            Workload::W6 => 5000,
        }
    }

    /// The operation count of a full run (`quick`: a smoke run that only shows it works).
    pub fn iterations(self, quick: bool) -> u64 {
        match (self, quick) {
            (Workload::W6, false) => 2_000,
            (Workload::W6, true) => 20,
            (_, false) => 100_000,
            (_, true) => 1_000,
        }
    }
}

/// A device kind the benchmark measures.
pub struct Kind {
    /// Its name: the firmware binary's, or `core` for the dictionary without a device.
    pub name: &'static str,
    /// The workloads it runs.
    pub workloads: &'static [Workload],
    /// Runs `n` operations of a workload on a fresh node of this kind.
    pub run: fn(Workload, u64) -> Result<Extra, String>,
}

/// Every device kind measured, with the firmware's variant of each. A CANopen device joins
/// with one line here; the WV58MR (J1939) joins with one line and a `run` of its own, as its
/// workloads go through its J1939 node.
pub const KINDS: &[Kind] = &[
    Kind { name: "sgh10", workloads: &Workload::ALL, run: |w, n| run(sgh10::Sgh10::new(sgh10::Variant::Sgh10), w, n) },
    Kind {
        name: "sgh50",
        workloads: &Workload::W1_W5,
        run: |w, n| run(sgh50::Sgh50::new(sgh50::Variant::Single), w, n),
    },
    Kind {
        name: "wv5800m",
        workloads: &Workload::W1_W5,
        run: |w, n| {
            let variant = wv5800m::Variant { model: wv5800m::Model::Wv, turns: wv5800m::Turns::Multi12 };
            run(wv5800m::Wv5800m::new(variant), w, n)
        },
    },
    Kind { name: "ap10t", workloads: &Workload::AP10T, run: |w, n| run(ap10t::Ap10t::new(), w, n) },
    Kind { name: "wv58mr", workloads: &Workload::J1939, run: run_j1939 },
    // The core alone: the SGH10's dictionary without its encoder behaviour (what issue 14's
    // "ours now" measured); the difference to `sgh10` is the device's share.
    Kind { name: "core", workloads: &Workload::W1_W5, run: |w, n| run(crate::TableOnly(sgh10::TABLE), w, n) },
];

/// What a run found besides its instruction count: W6's flash wear over [`WEAR_PAGES`] pages.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Extra {
    /// Page erases.
    pub erases: u64,
    /// Bytes programmed (half-word writes times two).
    pub bytes_written: u64,
}

impl Extra {
    /// Erases per page written, in hundredths: issue 14's goal is at most one (100), a page
    /// erased only once it is full, not at every save. The pages written are the bytes
    /// programmed in whole pages, rounded up: a page whose last few bytes are too few for the
    /// next save counts as full.
    pub fn erases_per_page_written_percent(&self) -> u64 {
        (self.erases * 100).div_ceil(self.bytes_written.div_ceil(PAGE as u64).max(1))
    }
}

/// How many pages W6's wear figure is taken over (filled in the steady state, before the
/// measured loop).
pub const WEAR_PAGES: u64 = 8;
/// Most saves W6 makes to fill them (a store that never erases fails the run).
const WEAR_SAVES_MAX: u64 = 10_000;

/// The parameter pages, as `memory.x` reserves them (four 1 KiB pages).
const REGION: Region = Region { offset: 0, pages: 4 };

/// The instant every operation happens at: 1 ms after start-up, nothing due before 1000 ms.
const NOW: Instant = Instant::from_millis(1);

const NODE_ID: u8 = 1;

/// Runs `n` operations of workload `w` on a node of `device` (node-ID 1, OPERATIONAL,
/// heartbeat 1000 ms) and checks their outcome; `Err` says what went wrong.
pub fn run<D: CanopenDevice>(device: D, w: Workload, n: u64) -> Result<Extra, String> {
    let mut params = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(device.table()));
    let mut node = Node::new(device, NODE_ID, Bitrate::K500);
    node.poll(Instant::ZERO);
    node.on_frame(&Frame::std(0x000, &[0x01, NODE_ID]), Instant::ZERO);
    node.on_frame(&heartbeat_1000(), Instant::ZERO);
    while let Some(out) = node.next_output() {
        if !matches!(out, Output::Frame(_)) {
            return Err(format!("start-up asked for {out:?}"));
        }
    }
    if node.nmt_state() != od_core::NmtState::Operational {
        return Err(format!("node in {:?} after NMT start", node.nmt_state()));
    }
    if node.next_deadline().is_some_and(|t| t <= NOW) {
        return Err(format!("a timer is due at {NOW:?}: next deadline {:?}", node.next_deadline()));
    }
    let mut extra = Extra::default();
    let done = match w {
        Workload::W1 => answers(&mut node, &upload_1018(), n),
        Workload::W2 => answers(&mut node, &heartbeat_1000(), n),
        Workload::W3 => answers(&mut node, &sync(), n),
        Workload::W4 => {
            for _ in 0..n {
                black_box(&mut node).poll(black_box(NOW));
                black_box(black_box(&node).next_deadline());
            }
            n
        }
        Workload::W5 => {
            let other = for_node_2();
            for _ in 0..n {
                black_box(&mut node).on_frame(black_box(&other), black_box(NOW));
            }
            n
        }
        Workload::W6 => {
            let request = save_request();
            // Each save has something to store: the heartbeat time alternates between 1000
            // and 1001 ms (set in the dictionary directly, so that W2's cost stays out).
            let heartbeat = node.core().od.pos(0x1017, 0).ok_or("no 1017h")?;
            // The wear figure first, in the steady state: once every page of the ring has been
            // started once, from the save that starts a page to the save that starts the
            // [`WEAR_PAGES`]-th page after it, so that it covers whole pages.
            let mut window = None;
            for _ in 0..WEAR_SAVES_MAX {
                toggle(&mut node, heartbeat);
                if !save(&mut node, &mut params, &request) {
                    return Err("a save before the measured loop failed".into());
                }
                let erases = erase_total(params.flash());
                match window {
                    None if erases > u64::from(REGION.pages) => window = Some((params.flash().ops(), erases)),
                    Some((ops, start)) if erases == start + WEAR_PAGES => {
                        extra.erases = WEAR_PAGES;
                        extra.bytes_written = (params.flash().ops() - ops - WEAR_PAGES) * WORD as u64;
                        break;
                    }
                    _ => {}
                }
            }
            if extra.erases == 0 {
                return Err(format!("no {WEAR_PAGES} pages filled in {WEAR_SAVES_MAX} saves"));
            }
            let mut saved = 0;
            for _ in 0..n {
                toggle(black_box(&mut node), heartbeat);
                saved += u64::from(save(black_box(&mut node), black_box(&mut params), black_box(&request)));
            }
            saved
        }
    };
    if done != n {
        return Err(format!("{w:?}: {done} of {n} operations did what they should"));
    }
    if let Some(out) = node.next_output() {
        return Err(format!("{w:?}: an operation left an extra output: {out:?}"));
    }
    check_one(&mut node, &mut params, w)?;
    Ok(extra)
}

/// The WV58MR's J1939 workloads: the node boots blank, claims its address (preferred EFh),
/// then every operation happens at one instant after the claim (999 ms) when nothing is due. The
/// requests come from address 20h.
pub fn run_j1939(w: Workload, n: u64) -> Result<Extra, String> {
    let mut node = J1939Node::boot(wv58mr::Wv58mr::new(wv5800m::Turns::Multi12), &Loaded::Blank);
    // Through the claim (its start delay and 250 ms) and the first cyclic PGNs, one
    // millisecond at a time.
    let mut t = Instant::ZERO;
    while t < Instant::from_millis(1000) {
        node.poll(t);
        while node.next_output().is_some() {}
        t = t.add_millis(1);
    }
    // The last poll's instant: nothing is due before the next deadline.
    let now = Instant::from_millis(999);
    if node.next_deadline().is_none_or(|d| d <= now) {
        return Err(format!("J1939: a timer is due at {now:?}: next deadline {:?}", node.next_deadline()));
    }
    let Some(me) = node.source_address() else { return Err("J1939: no address claimed after 1000 ms".into()) };
    let client = Address(0x20);
    let read = CamRequest::Read { index: 0x1018, sub: 1 }.frame(me, client);
    let write = CamRequest::Write { index: 0x3000, sub: 2, value: 1000, len: Some(2) }.frame(me, client);
    let other = CamRequest::Read { index: 0x1018, sub: 1 }.frame(Address(me.0.wrapping_add(1)), client);
    let done = match w {
        Workload::W1 => answers_at(&mut node, &read, now, n),
        Workload::W2 => answers_at(&mut node, &write, now, n),
        Workload::W4 => {
            for _ in 0..n {
                black_box(&mut node).poll(black_box(now));
                black_box(black_box(&node).next_deadline());
            }
            n
        }
        Workload::W5 => {
            for _ in 0..n {
                black_box(&mut node).on_frame(black_box(&other), black_box(now));
            }
            n
        }
        Workload::W3 | Workload::W6 => return Err(format!("{w:?} is not a J1939 workload")),
    };
    if done != n {
        return Err(format!("{w:?}: {done} of {n} operations did what they should"));
    }
    if let Some(out) = node.next_output() {
        return Err(format!("{w:?}: an operation left an extra output: {out:?}"));
    }
    // One more, checked in full: the CAM11 answer to the client, or nothing.
    let cam11 = |f: &Frame, expect: CamResponse| {
        let id = Identifier::parse(f.id.raw()).ok();
        id.is_some_and(|id| id.pgn() == Pgn::CAM11 && id.destination() == Some(client) && id.source() == me)
            && CamResponse::parse(f.payload()) == Ok(expect)
    };
    let (frame, expect) = match w {
        Workload::W1 => (read, Some(CamResponse::Read { index: 0x1018, sub: 1, value: 0x195, len: 4 })),
        Workload::W2 => (write, Some(CamResponse::Written { index: 0x3000, sub: 2 })),
        Workload::W4 => {
            node.poll(now);
            return match node.next_output() {
                None => Ok(Extra::default()),
                Some(out) => Err(format!("W4: output {out:?}")),
            };
        }
        _ => (other, None),
    };
    node.on_frame(&frame, now);
    match (node.next_output(), node.next_output(), expect) {
        (None, None, None) => Ok(Extra::default()),
        (Some(Output::Frame(f)), None, Some(e)) if cam11(&f, e) => Ok(Extra::default()),
        (first, second, _) => Err(format!("{w:?}: unexpected outputs {first:?}, {second:?}")),
    }
}

/// Hands `frame` to the node `n` times at `now`, taking one output after each; how many were
/// frames.
fn answers_at<S: Station>(node: &mut S, frame: &Frame, now: Instant, n: u64) -> u64 {
    let mut frames = 0;
    for _ in 0..n {
        black_box(&mut *node).on_frame(black_box(frame), black_box(now));
        if let Some(Output::Frame(f)) = black_box(&mut *node).next_output() {
            black_box(f);
            frames += 1;
        }
    }
    frames
}

/// Page erases so far, over every page.
fn erase_total(flash: &RamFlash) -> u64 {
    (0..flash.bytes().len() / PAGE).map(|p| u64::from(flash.erase_count(p))).sum()
}

/// The SDO download of 1017h = 1000 ms (W2, and the setup's heartbeat).
fn heartbeat_1000() -> Frame {
    Frame::std(0x600 + NODE_ID as u16, &[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00])
}

/// Hands `frame` to the node `n` times at [`NOW`], taking one output after each; how many were frames.
fn answers<S: Station>(node: &mut S, frame: &Frame, n: u64) -> u64 {
    answers_at(node, frame, NOW, n)
}

/// Flips the lowest bit of the value at `pos` (W6: a value for the next save to store).
fn toggle<D: CanopenDevice>(node: &mut Node<D>, pos: usize) {
    let od = &mut node.split().1.od;
    od.set(pos, od.get(pos) ^ 1);
}

/// One 1010h.01 "save" as the firmware performs it: the request, the store the node asks for,
/// its result, and the SDO answer taken. Whether all of it happened.
fn save<D: CanopenDevice>(node: &mut Node<D>, params: &mut ParamFlash<RamFlash>, request: &Frame) -> bool {
    node.on_frame(request, NOW);
    let Some(Output::Store(groups)) = node.next_output() else { return false };
    let result = params.save(node.core(), groups);
    let ok = result.is_ok();
    node.store_done(result.map_err(|_| ()), NOW);
    ok && matches!(node.next_output(), Some(Output::Frame(_)))
}

/// One more operation, outside the measured loop, whose outputs are checked in full.
fn check_one<D: CanopenDevice>(
    node: &mut Node<D>,
    params: &mut ParamFlash<RamFlash>,
    w: Workload,
) -> Result<(), String> {
    let sdo = |cmd: u8, index: u16, sub: u8| {
        move |f: &Frame| {
            f.id == CanId::Std(0x580 + NODE_ID as u16)
                && f.payload().len() == 8
                && f.payload()[..4] == [cmd, index as u8, (index >> 8) as u8, sub]
        }
    };
    match w {
        Workload::W1 => {
            node.on_frame(&upload_1018(), NOW);
            one_frame(node, w, sdo(0x43, 0x1018, 1))
        }
        Workload::W2 => {
            node.on_frame(&heartbeat_1000(), NOW);
            one_frame(node, w, sdo(0x60, 0x1017, 0))
        }
        Workload::W3 => {
            node.on_frame(&sync(), NOW);
            one_frame(node, w, |f| f.id == CanId::Std(0x280 + NODE_ID as u16) && f.payload().len() == 6)
        }
        Workload::W4 => {
            node.poll(NOW);
            match (node.next_output(), node.next_deadline()) {
                (None, Some(t)) if t > NOW => Ok(()),
                (out, next) => Err(format!("W4: output {out:?}, next deadline {next:?}")),
            }
        }
        Workload::W5 => {
            node.on_frame(&for_node_2(), NOW);
            match node.next_output() {
                None => Ok(()),
                Some(out) => Err(format!("W5: answered {out:?}")),
            }
        }
        Workload::W6 => {
            node.on_frame(&save_request(), NOW);
            let Some(Output::Store(groups)) = node.next_output() else { return Err("W6: no store".into()) };
            let result = params.save(node.core(), groups);
            node.store_done(result.map_err(|_| ()), NOW);
            result.map_err(|e| format!("W6: {e:?}"))?;
            one_frame(node, w, sdo(0x60, 0x1010, 1))
        }
    }
}

/// Exactly one output, a frame that `expect` accepts.
fn one_frame<D: CanopenDevice>(node: &mut Node<D>, w: Workload, expect: impl Fn(&Frame) -> bool) -> Result<(), String> {
    match (node.next_output(), node.next_output()) {
        (Some(Output::Frame(f)), None) if expect(&f) => Ok(()),
        (first, second) => Err(format!("{w:?}: unexpected outputs {first:?}, {second:?}")),
    }
}

/// W1's request: upload 1018h sub 1.
fn upload_1018() -> Frame {
    Frame::std(0x600 + NODE_ID as u16, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])
}

/// The SYNC (1005h default 80h).
fn sync() -> Frame {
    Frame::std(0x080, &[])
}

/// W5's frame: the same upload request, for node 2.
fn for_node_2() -> Frame {
    Frame::std(0x602, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])
}

/// W6's request: 1010h sub 1 = "save".
fn save_request() -> Frame {
    Frame::std(0x600 + NODE_ID as u16, &[0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e'])
}

/// The instruction count in a callgrind output file: its `totals:` line (or `summary:`, which
/// older versions write instead), first event (Ir).
pub fn callgrind_total(out: &str) -> Option<u64> {
    let line =
        out.lines().find(|l| l.starts_with("totals:")).or_else(|| out.lines().find(|l| l.starts_with("summary:")))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Instructions per operation from the counts at 0 and at `n` operations, rounded.
pub fn per_operation(at_zero: u64, at_n: u64, n: u64) -> u64 {
    (at_n.saturating_sub(at_zero) + n / 2) / n.max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_workload_does_what_it_says_on_every_kind() {
        for kind in KINDS {
            for &w in kind.workloads {
                let extra = (kind.run)(w, 3).unwrap_or_else(|e| panic!("{} {w:?}: {e}", kind.name));
                if w == Workload::W6 {
                    assert!(extra.erases > 0 && extra.bytes_written > 0, "{extra:?}");
                }
            }
        }
    }

    #[test]
    fn callgrind_totals_are_read() {
        let out = "events: Ir\nfn=main\n1 5\nsummary: 123\ntotals: 4567\n";
        assert_eq!(callgrind_total(out), Some(4567));
        assert_eq!(callgrind_total("events: Ir\nsummary: 99\n"), Some(99));
        assert_eq!(callgrind_total("events: Ir\n"), None);
        assert_eq!(per_operation(1000, 1000 + 4175, 10), 418);
        assert_eq!(Extra { erases: 4, bytes_written: 2048 }.erases_per_page_written_percent(), 200);
        assert_eq!(Extra { erases: 1, bytes_written: 3 * 1024 }.erases_per_page_written_percent(), 34);
        // Eight pages filled to their last 8 bytes, eight erases: one per page.
        assert_eq!(Extra { erases: 8, bytes_written: 8 * 1016 }.erases_per_page_written_percent(), 100);
        // The old store: an erase for every 40-byte save.
        assert_eq!(Extra { erases: 32, bytes_written: 1280 }.erases_per_page_written_percent(), 1600);
    }
}
