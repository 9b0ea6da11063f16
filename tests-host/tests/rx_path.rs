//! The firmware's receive path as a host model, at full load (1 Mbit/s, about 8,000 frames a
//! second) with a parameter save's 40 ms page erase in the middle (issue 15, D-FW-9).
//!
//! What the firmware does (`firmware/src/can.rs`, `firmware/src/run.rs`): the bxCAN puts each
//! frame that passes the node's acceptance filters into its receive FIFO 0 (three mailboxes);
//! the FIFO interrupt moves them at once into the board's ring of `RX_DEPTH` frames
//! (`board_plan::rxq`; a full ring drops the frame and the loop reports it as an `RxOverrun`);
//! the main loop takes every queued frame, calls `on_frame` and carries out the node's outputs
//! after each, then reads the controller's events (FOVR, a frame lost to a full FIFO, is one
//! `RxOverrun` however many were lost). A `Store` output blocks the loop for the save: the page
//! erase (at most 40 ms on the F103) and the half-word writes (at most 70 µs each); while the
//! flash is busy the CPU cannot fetch from it, so neither the loop nor the interrupt runs and only
//! the three FIFO mailboxes take frames.
//!
//! The model runs the real node (an SGH10, node 10, OPERATIONAL, TPDO1 every 10 ms, heartbeat
//! 50 ms) on a bus filled by other nodes (SYNC every 10 ms, RPDO1 frames on 20Ah, NMT for node
//! 11 and neighbours of its identifiers that the filters reject, as `bus_load.rs`), a master
//! reading by SDO every 2 ms, and a 1010h "save" at 1 s. Printed and checked: the software
//! queue's deepest fill at full load (a per-frame cost of 50 µs, generous for the F103 at 72 MHz),
//! the frames that pass the filters in the save's stall and so the depth a queue would need to
//! keep them all, the frames lost beyond the FIFO, one `RxOverrun` reported, no EMCY for it (no
//! manual lists a code, D-ENC-5), the save answered, nothing in the dictionary changed but the
//! saved value, the node still OPERATIONAL with its heartbeat, answering the next SDO requests.

use std::collections::VecDeque;

use od_core::node::{BusEvent, Output};
use od_core::od::GroupMask;
use od_core::storage::{identity, ParamFlash};
use od_core::{CanId, Frame, Instant, NmtState};
use tests_host::encoder::{download_request, upload_request};
use tests_host::flash::RamFlash;
use tests_host::invariants::{boot_with_id, check_values, Kind, REGION};

const ID: u16 = 10;
/// bxCAN receive FIFO 0: three mailboxes.
const HW_FIFO: usize = 3;
/// `firmware/src/can.rs` `RX_DEPTH` (checked against the source below).
const RX_DEPTH: usize = 32;
/// The loop's work per received frame (on_frame and its outputs), an upper bound.
const COST_US: u64 = 50;
/// F103 page erase, maximum (datasheet: 20..40 ms).
const ERASE_US: u64 = 40_000;
/// F103 half-word programming, maximum (datasheet: 52.5..70 µs).
const WRITE_US: u64 = 70;

/// Bit times of a data frame with an 11-bit identifier at 1 Mbit/s (as `bus_load.rs`).
fn frame_us(f: &Frame) -> u64 {
    let n = f.len as u64;
    47 + 8 * n + (34 + 8 * n) / 10
}

#[test]
fn the_model_uses_the_firmware_queue_depth() {
    let can = include_str!("../../firmware/src/can.rs");
    assert!(can.contains(&format!("pub const RX_DEPTH: usize = {RX_DEPTH};")), "firmware RX_DEPTH changed");
}

#[derive(Default, Debug)]
struct Figures {
    frames: u64,
    accepted: u64,
    queue_max: usize,
    stall_us: u64,
    stall_accepted: u64,
    fifo_lost: u64,
    queue_dropped: u64,
    overrun_events: u64,
    sdo_answered: u64,
}

#[test]
fn a_save_at_full_load_loses_frames_beyond_the_fifo_counted_and_nothing_else() {
    let mut node = boot_with_id(Kind::Sgh10, ID as u8);
    let table = Kind::Sgh10.table();
    let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(table));
    let mut now = Instant::ZERO;
    node.poll(now);
    for req in [download_request(0x1017, 0, 2, 50), download_request(0x1800, 5, 2, 10)] {
        node.on_frame(&Frame::std(0x600 + ID, &req), now);
    }
    node.on_frame(&Frame::std(0, &[0x01, ID as u8]), now);
    while node.next_output().is_some() {}
    // The node's acceptance filters: NMT, SYNC, its SDO requests, LSS and its valid RPDOs.
    let mut ids = vec![CanId::Std(0), CanId::Std(0x80), CanId::Std(0x600 + ID), CanId::Std(0x7E5)];
    for n in 0..4u16 {
        if let Some(v) = node.core().od.value(0x1400 + n, 1).filter(|v| v & 0x8000_0000 == 0) {
            ids.push(CanId::from_cob_id(v));
        }
    }
    let accepts = |f: &Frame| ids.contains(&f.id) && !f.rtr;

    let mut fig = Figures::default();
    let mut fifo: VecDeque<Frame> = VecDeque::new();
    let mut queue: VecDeque<Frame> = VecDeque::new();
    let mut fovr = false;
    let mut busy_until = Instant::ZERO; // the loop works on received frames until then
    let mut stall: Option<(Instant, Instant)> = None; // the save's erase and writes
    let mut save_answer = None;
    let mut beats = Vec::new();
    let (mut k, mut master_next, mut master_waiting) = (0u64, Instant::from_millis(2), false);
    let save_at = Instant::from_millis(1000);
    let mut save_sent = false;
    let end = Instant::from_millis(2000);
    let before = node.core().od.clone();

    while now < end {
        // The next frame on the bus: the master's request when due, else the others' traffic.
        k += 1;
        let frame = if !master_waiting && now >= master_next {
            master_waiting = true;
            if !save_sent && now >= save_at {
                save_sent = true;
                Frame::std(0x600 + ID, &download_request(0x1010, 1, 4, u32::from_le_bytes(*b"save")))
            } else {
                Frame::std(0x600 + ID, &upload_request(0x1000, 0))
            }
        } else if now.as_micros() / 10_000 != (now.as_micros() + 120) / 10_000 {
            Frame::std(0x80, &[])
        } else {
            match k % 8 {
                0 => Frame::std(0x200 + ID, &[k as u8, 0, 0, 0, 0, 0]),
                1 => Frame::std(0, &[0x01, (ID + 1) as u8]),
                2 => Frame::std(0x600 + ID + 1, &upload_request(0x1000, 0)),
                3 => Frame::std(0x700 + ID - 1, &[0x05]),
                n => Frame::std([0x180 + ID + 1, 0x580 + ID - 1, 0x280 + ID + 1, 0x7E4][n as usize % 4], &[0; 8]),
            }
        };
        now = now.add_micros(frame_us(&frame));
        fig.frames += 1;
        let stalled = |t: Instant, stall: Option<(Instant, Instant)>| stall.is_some_and(|(a, b)| a <= t && t < b);

        // The controller: the filters, then the FIFO; the interrupt empties it unless stalled.
        if accepts(&frame) {
            fig.accepted += 1;
            if stalled(now, stall) {
                fig.stall_accepted += 1;
            }
            if fifo.len() < HW_FIFO {
                fifo.push_back(frame);
            } else {
                fig.fifo_lost += 1;
                fovr = true;
            }
        }
        if !stalled(now, stall) {
            while let Some(f) = fifo.pop_front() {
                if queue.len() < RX_DEPTH {
                    queue.push_back(f);
                } else {
                    fig.queue_dropped += 1;
                }
            }
            fig.queue_max = fig.queue_max.max(queue.len());
        }

        // The loop: one received frame per COST_US while not stalled; then the events; polls.
        while !queue.is_empty() && busy_until <= now && !stalled(now, stall) {
            let f = queue.pop_front().expect("a frame");
            let t = busy_until.max(now.add_micros(0));
            node.on_frame(&f, t);
            busy_until = t.add_micros(COST_US);
            while let Some(o) = node.next_output() {
                match o {
                    Output::Frame(a) if a.id == CanId::Std(0x580 + ID) => {
                        if a.payload()[..2] == [0x60, 0x10] {
                            save_answer = Some(a);
                        }
                        assert_ne!(a.payload()[0], 0x80, "abort {a:?}");
                        fig.sdo_answered += 1;
                        master_waiting = false;
                        master_next = t.add_millis(2);
                    }
                    Output::Frame(a) => assert_ne!(a.id.raw() & 0x780, 0x80, "EMCY {a:?}"),
                    Output::Store(mask) => {
                        assert_eq!(mask, GroupMask::ALL);
                        let ops = flash.flash().ops();
                        flash.save(node.core(), mask).expect("save");
                        let us = ERASE_US + (flash.flash().ops() - ops - 1) * WRITE_US;
                        stall = Some((t, t.add_micros(us)));
                        fig.stall_us = us;
                        busy_until = t.add_micros(us);
                        node.store_done(true, busy_until);
                    }
                    Output::SetBitrate(_) => unreachable!(),
                }
            }
        }
        if !stalled(now, stall) {
            if std::mem::take(&mut fovr) {
                fig.overrun_events += 1;
                node.on_bus_event(BusEvent::RxOverrun, now);
            }
            while let Some(t) = node.next_deadline().filter(|t| *t <= now) {
                node.poll(t.max(busy_until.min(now)));
                while let Some(o) = node.next_output() {
                    match o {
                        Output::Frame(a) if a.id == CanId::Std(0x700 + ID) => beats.push(t),
                        Output::Frame(a) => assert_ne!(a.id.raw() & 0x780, 0x80, "EMCY {a:?}"),
                        other => panic!("{other:?} from a poll"),
                    }
                }
            }
        }
    }

    eprintln!(
        "rx path at full load: {} frames/s, {} accepted/s; software queue at most {} of {RX_DEPTH}; \
         save stall {} us with {} accepted frames (the depth a queue would need), {} lost beyond the \
         {HW_FIFO}-frame FIFO, {} dropped by the software queue, {} RxOverrun reported, {} SDO answers",
        fig.frames / 2,
        fig.accepted / 2,
        fig.queue_max,
        fig.stall_us,
        fig.stall_accepted,
        fig.fifo_lost,
        fig.queue_dropped,
        fig.overrun_events,
        fig.sdo_answered
    );
    assert!((7500..=10_000).contains(&(fig.frames / 2)), "the bus is full");
    assert!(fig.queue_max <= 4, "the loop keeps up: the queue held {}", fig.queue_max);
    assert_eq!(fig.queue_dropped, 0);
    assert!(fig.stall_us >= ERASE_US && fig.stall_accepted > HW_FIFO as u64, "{fig:?}");
    assert_eq!(fig.fifo_lost, fig.stall_accepted - HW_FIFO as u64, "lost exactly the frames beyond the FIFO");
    assert_eq!(fig.overrun_events, 1, "one FOVR, one RxOverrun");
    assert_eq!(save_answer.map(|a| a.data), Some([0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]), "the save answered");
    assert!(fig.sdo_answered > 400, "SDO answered before and after the save: {}", fig.sdo_answered);
    // Nothing corrupted: every value in limits, the dictionary as before but what the node's
    // own timers and the position change (none at rest), still OPERATIONAL, heartbeat going on.
    check_values(node.core()).unwrap();
    let after = &node.core().od;
    for (pos, e) in after.table().iter().enumerate() {
        if ![0x1001, 0x1002, 0x1003, 0x5000].contains(&e.index) {
            assert_eq!(after.get(pos), before.get(pos), "{:04X}h.{:02X} changed", e.index, e.sub);
        }
    }
    assert_eq!(node.nmt_state(), NmtState::Operational);
    let late = beats.iter().filter(|t| **t > Instant::from_millis(1100)).count();
    assert!(late >= 17, "heartbeats after the save: {late}");
}
