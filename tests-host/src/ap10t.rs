//! An AP10T on a segment: its node, its keys and what its front panel shows.
//!
//! The shell's part of the display: key edges go to the device ([`Display::press`],
//! [`Display::release`]); the screen, the LEDs and the backlight are read at an instant
//! ([`Display::view`], [`Display::rows`]). The live view's line is the view at the last time
//! the station ran ([`Station::panel`]).

use std::any::Any;
use std::cell::Cell;

use od_core::devices::ap10t::{Ap10t, Key, View};
use od_core::lss::Lss;
use od_core::nmt::NmtState;
use od_core::node::{BusEvent, Context, Node, Output};
use od_core::shell::RxIds;
use od_core::storage::Loaded;
use od_core::time::earliest;
use od_core::{Bitrate, Frame, Instant};

use crate::segment::Station;

/// An AP10T node as a station.
pub struct Display {
    node: Node<Ap10t>,
    /// The last instant the station ran: the live view shows the panel as it was then.
    now: Cell<Instant>,
}

impl Display {
    /// A display around `node`.
    pub fn new(node: Node<Ap10t>) -> Display {
        Display { node, now: Cell::new(Instant::ZERO) }
    }

    /// A display powered on from what its flash holds (`Node::boot`).
    pub fn boot(loaded: &Loaded) -> Display {
        Display::new(Node::boot(Ap10t::new(), loaded))
    }

    /// A display configured before with `node_id` and `bitrate` (no automatic detection).
    pub fn configured(node_id: u8, bitrate: Bitrate) -> Display {
        Display::new(Node::new(Ap10t::new(), node_id, bitrate))
    }

    /// The node.
    pub fn node(&self) -> &Node<Ap10t> {
        &self.node
    }

    /// `key` pressed at `now`.
    pub fn press(&mut self, key: Key, now: Instant) {
        let (device, core) = self.node.split();
        device.press(core, key, now);
        self.now.set(now);
    }

    /// `key` released at `now`.
    pub fn release(&mut self, key: Key, now: Instant) {
        let (device, core) = self.node.split();
        device.release(core, key, now);
        self.now.set(now);
    }

    /// The CAN controller reported `event` at `now`.
    pub fn bus_event(&mut self, event: BusEvent, now: Instant) {
        self.node.on_bus_event(event, now);
        self.now.set(now);
    }

    /// What the operator sees at `now`.
    pub fn view(&self, now: Instant) -> View {
        self.node.device().view(now)
    }

    /// The two rows as text at `now` (as read: blanks at the ends removed).
    pub fn rows(&self, now: Instant) -> [String; 2] {
        self.view(now).screen.rows.map(|r| r.text().to_string())
    }
}

impl od_core::Station for Display {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.now.set(now);
        self.node.on_frame(frame, now)
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.bus_event(event, now)
    }
    fn poll(&mut self, now: Instant) {
        self.now.set(now);
        if self.node.next_deadline().is_some_and(|t| t <= now) {
            self.node.poll(now)
        }
    }
    /// The node's deadline, or earlier when the panel changes by itself (blinking, a menu
    /// time-out), so that the live view shows it.
    fn next_deadline(&self) -> Option<Instant> {
        earliest(self.node.next_deadline(), self.node.device().next_change(self.now.get()))
    }
    fn next_output(&mut self) -> Option<Output> {
        self.node.next_output()
    }
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.node.store_done(result, now)
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
    fn listen_only(&self) -> bool {
        self.node.listen_only()
    }
}

impl Station for Display {
    fn nmt(&self) -> Option<NmtState> {
        Some(self.node.nmt_state())
    }
    fn lss(&self) -> Option<&Lss> {
        Some(self.node.lss())
    }
    fn panel(&self) -> Option<String> {
        Some(self.view(self.now.get()).to_string())
    }
    fn as_any_mut(&mut self) -> Option<&mut dyn Any> {
        Some(self)
    }
}
