//! The bxCAN as the node's bus: bit timing from `board_plan::timing`, acceptance filters from
//! the node's receive identifiers, a receive queue that the interrupt fills without ever
//! blocking, a transmit queue that hands the mailboxes the most urgent frame first, and the
//! controller's error state as the core's [`BusEvent`]s.
//!
//! Bus-off recovery is the controller's own (automatic bus-off management, set by Embassy's
//! `enable`): after 128 × 11 recessive bits it is back, and [`Bus::events`] reports both
//! changes so the device raises and clears its EMCYs and LED states.

use board_plan::errors::{ErrorTracker, Esr};
use board_plan::filters::{each_bank, mask32, Bank, BANKS};
use board_plan::mailbox::{self, Slot};
use board_plan::timing;
use board_plan::txq::TxQueue;
use boards::mcu::CanPeri;
use boards::mcu::{RX, RX_READY, TX_DONE};
use core::future::poll_fn;
use core::task::Poll;
use embassy_stm32::pac;
use embassy_time::{Duration, Instant};
use od_core::node::BusEvent;
use od_core::{Bitrate, Frame};

pub use od_core::RxId;

/// Frames the receive queue holds between two turns of the loop (the hardware FIFO has 3): the
/// board's ring, `board_plan::rxq::DEPTH` (checked here at compile time).
pub const RX_DEPTH: usize = 32;
const _: () = assert!(RX_DEPTH == board_plan::rxq::DEPTH);

/// How long a bit-rate switch waits for the frames queued at the old rate: a few frames even at
/// 10 kbit/s (about 13 ms a frame), and well inside the watchdog's 256 ms.
pub const FLUSH_TIMEOUT: Duration = Duration::from_millis(100);

/// The node's CAN bus.
pub struct Bus {
    _can: CanPeri,
    queue: TxQueue,
    errors: ErrorTracker,
}

/// Sets the bit timing for `rate` (`board_plan::timing`, computed at compile time), in silent
/// mode or not: CAN_BTR written whole (loop-back off) in initialisation mode, then back to
/// sleep mode, where [`enable`] takes it from (the steps of Embassy's `modify_config`).
fn set_timing(rate: Bitrate, silent: bool) {
    let can = pac::CAN;
    can.mcr().modify(|w| {
        w.set_sleep(false);
        w.set_inrq(true);
    });
    while {
        let msr = can.msr().read();
        msr.slak() || !msr.inak()
    } {}
    let silm = if silent { 1 << 31 } else { 0 };
    can.btr().write(|w| w.0 = timing::of(rate).btr() | silm);
    boards::mcu::can_sleep();
}

/// The acceptance filters, written whole rather than through the driver's per-bank calls
/// (RM0008 24.7.4, 24.9.5): the filters in initialisation mode and every bank off, then bank by
/// bank from 0 its two registers, mode and scale, then all of them on FIFO 0 (frames keep their
/// order) and the banks used on.
struct FilterWriter {
    /// Banks written so far.
    n: usize,
    /// Identifier-list mode (else mask mode), a bit per bank (CAN_FM1R).
    list: u32,
    /// One 32-bit filter (else two 16-bit ones), a bit per bank (CAN_FS1R).
    scale32: u32,
}

impl FilterWriter {
    fn begin() -> FilterWriter {
        let can = pac::CAN;
        can.fmr().modify(|w| w.set_finit(true));
        can.fa1r().write(|w| w.0 = 0);
        FilterWriter { n: 0, list: 0, scale32: 0 }
    }

    /// The next bank; nothing once all [`BANKS`] are used.
    fn bank(&mut self, list: bool, scale32: bool, (fr1, fr2): (u32, u32)) {
        if self.n >= BANKS {
            return;
        }
        let bank = pac::CAN.fb(self.n);
        bank.fr1().write(|w| w.0 = fr1);
        bank.fr2().write(|w| w.0 = fr2);
        self.list |= (list as u32) << self.n;
        self.scale32 |= (scale32 as u32) << self.n;
        self.n += 1;
    }

    /// The next bank as `board_plan::filters` packed it.
    fn put(&mut self, bank: Bank) {
        let (list, scale32) = bank.mode();
        self.bank(list, scale32, bank.registers());
    }

    fn end(self) {
        let can = pac::CAN;
        can.fm1r().write(|w| w.0 = self.list);
        can.fs1r().write(|w| w.0 = self.scale32);
        can.ffa1r().write(|w| w.0 = 0);
        can.fa1r().write(|w| w.0 = (1 << self.n) - 1);
        can.fmr().modify(|w| w.set_finit(false));
    }
}

impl Bus {
    /// Configures the controller for `rate` and joins the bus (after 11 recessive bits); the
    /// board's receive interrupts fill `boards::mcu::RX`. No filter bank is enabled until
    /// [`Bus::set_filters`]: the controller receives nothing before the node says what it wants.
    pub fn start(can: CanPeri, rate: Bitrate) -> Bus {
        FilterWriter::begin().end();
        set_timing(rate, false);
        enable();
        Bus { _can: can, queue: TxQueue::default(), errors: ErrorTracker::default() }
    }

    /// Switches to `rate` (LSS activate bit timing, a pending rate after a reset, a candidate of
    /// the automatic bit-rate detection). The frames the node queued before the switch belong to
    /// the old rate: they go out first, as long as the bus takes them within [`FLUSH_TIMEOUT`];
    /// what is left then is dropped. The controller re-joins the bus at the new rate after 11
    /// recessive bits; `silent`: in silent mode (it sends nothing, not even an ACK or an error
    /// frame, while the node detects the rate, `Node::listen_only`). It returns when the
    /// controller is back on the bus: the firmware's one task has nothing else to run meanwhile
    /// (the interrupts still fill the receive ring), so it polls the mailboxes and the clock
    /// rather than sleeping on them, which keeps the loop's future free of await points for it.
    pub fn set_bitrate(&mut self, rate: Bitrate, silent: bool) {
        let deadline = Instant::now() + FLUSH_TIMEOUT;
        loop {
            self.pump();
            if (self.queue.is_empty() && empty_mailboxes() == 3) || Instant::now() >= deadline {
                break;
            }
        }
        for i in 0..3 {
            abort(i);
        }
        self.queue.clear();
        set_timing(rate, silent);
        enable();
    }

    /// Opens the acceptance filters to every frame (while the node detects the rate: any frame
    /// received without error proves it).
    pub fn accept_all(&mut self) {
        let mut filters = FilterWriter::begin();
        filters.put(Bank::AcceptAll);
        filters.end();
    }

    /// Programs the acceptance filters to pass exactly `ids`, and the 29-bit data frames each
    /// (identifier, mask) of `masks` passes (a J1939 node's), one bank each after the lists (all
    /// banks on FIFO 0, so frames keep their order).
    pub fn set_filters(&mut self, ids: &[RxId], masks: &[(u32, u32)]) {
        let mut filters = FilterWriter::begin();
        each_bank(ids, BANKS.saturating_sub(masks.len()), |bank| filters.put(bank));
        for &(id, mask) in masks {
            filters.bank(false, true, mask32(id, mask));
        }
        filters.end();
    }

    /// Queues a frame for transmission.
    pub fn send(&mut self, frame: Frame) {
        self.queue.push(frame);
    }

    /// Frames dropped because the transmit queue was full (the bus is off or jammed).
    pub fn dropped(&self) -> u32 {
        self.queue.dropped()
    }

    /// Hands the mailboxes the most urgent waiting frames, through their registers
    /// (`board_plan::mailbox` decides where each goes). A frame a mailbox gives up for a more
    /// urgent one goes back into the queue.
    pub fn pump(&mut self) {
        let can = pac::CAN;
        while let Some(frame) = self.queue.peek() {
            let tsr = can.tsr().read();
            let pending = [0, 1, 2].map(|i| (!tsr.tme(i)).then(|| can.tx(i).tir().read().0));
            let (i, back) = match mailbox::choose(frame, pending) {
                Slot::Free(i) => (i, None),
                Slot::Replace(i) => (i, abort(i)),
                Slot::Wait => break,
            };
            let Some(frame) = self.queue.pop() else { break };
            let [tir, tdtr, tdlr, tdhr] = mailbox::registers(&frame);
            let mb = can.tx(i);
            mb.tdtr().write(|w| w.0 = tdtr);
            mb.tdlr().write(|w| w.0 = tdlr);
            mb.tdhr().write(|w| w.0 = tdhr);
            mb.tir().write(|w| w.0 = tir | mailbox::TXRQ);
            if let Some(back) = back {
                self.queue.push(back);
            }
        }
    }

    /// The next received frame, if any.
    pub fn receive(&mut self) -> Option<Frame> {
        RX.with(|rx| rx.pop())
    }

    /// What changed in the controller since the last look, handed to `event` in this order: a
    /// frame lost to a full receive FIFO, the last protocol error, the error counters and the
    /// fault confinement state.
    pub fn events(&mut self, mut event: impl FnMut(BusEvent)) {
        let can = pac::CAN;
        // A frame lost to the full hardware FIFO or to the full software ring: one overrun.
        let fifo = can.rfr(0).read().fovr();
        if fifo {
            can.rfr(0).write(|w| w.set_fovr(true));
        }
        if RX.with(|rx| rx.take_overflow()) | fifo {
            event(BusEvent::RxOverrun);
        }
        let esr = Esr::from_bits(can.esr().read().0);
        if (1..=6).contains(&esr.lec) {
            // "Set by software": a new error shows up as a code 1..6 again.
            can.esr().write_value(pac::can::regs::Esr(7 << 4));
        }
        self.errors.each(esr, event);
    }

    /// Waits until a frame is received or, while frames wait in the queue, a mailbox can take
    /// the next one. If a mailbox is free already, the frame was refused because one with the
    /// same identifier is still pending (the bxCAN would not keep their order): then it waits
    /// for every mailbox to empty, rather than return at once and spin.
    pub async fn ready(&mut self) {
        let waiting = !self.queue.is_empty();
        let all = empty_mailboxes() > 0;
        poll_fn(|cx| {
            RX_READY.register(cx.waker());
            if !RX.with(|rx| rx.is_empty()) {
                return Poll::Ready(());
            }
            if waiting {
                TX_DONE.register(cx.waker());
                let empty = empty_mailboxes();
                if empty == 3 || (!all && empty > 0) {
                    return Poll::Ready(());
                }
            }
            Poll::Pending
        })
        .await
    }
}

/// Leaves sleep mode with automatic bus-off management on, and waits until the controller has
/// joined the bus (11 recessive bits): what Embassy's `Can::enable` does, without yielding to an
/// executor that has nothing else to run.
fn enable() {
    let can = pac::CAN;
    while can.msr().read().slak() {
        can.mcr().modify(|w| {
            w.set_abom(true);
            w.set_sleep(false);
        });
    }
}

/// Aborts the frame in mailbox `i` and returns it; `None` if the mailbox was empty or its frame
/// went out before the abort took effect.
fn abort(i: usize) -> Option<Frame> {
    let can = pac::CAN;
    if can.tsr().read().tme(i) {
        return None;
    }
    can.tsr().write(|w| w.set_abrq(i, true));
    // The abort completes once the frame is out of the mailbox: sent (TXOK) or not.
    let tsr = loop {
        let tsr = can.tsr().read();
        if !tsr.abrq(i) {
            break tsr;
        }
    };
    if tsr.txok(i) {
        return None;
    }
    let mb = can.tx(i);
    Some(mailbox::frame_of([mb.tir().read().0, mb.tdtr().read().0, mb.tdlr().read().0, mb.tdhr().read().0]))
}

/// How many of the three transmit mailboxes are empty.
fn empty_mailboxes() -> usize {
    let tsr = pac::CAN.tsr().read();
    (0..3).filter(|&i| tsr.tme(i)).count()
}
