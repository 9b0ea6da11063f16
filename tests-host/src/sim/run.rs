//! The simulator in real time: one [`Segment`] per bus, driven at its nodes' deadlines by the
//! wall clock, served to socketcand clients over TCP, shown in a live view.
//!
//! Threads: one accepting connections, one reader and one writer per client; the main loop
//! owns every segment. Each client's frames wait in a small queue of their own
//! ([`CLIENT_FRAMES`]); the main loop takes them one at a time, round robin between the
//! clients of a bus, at the pace the bus's bit rate allows ([`frame_time`]). A client that
//! sends faster than its bus carries fills its queue, and its reader stops reading its socket
//! until there is room: TCP makes the client wait, not the others. What goes to a client is
//! bounded in bytes ([`CLIENT_BYTES`]); one that does not read loses frames beyond that.
//! After every frame the bus carries, the nodes' outputs are drained, as the firmware does.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError};
use std::sync::{Arc, Condvar, Mutex};
use std::thread;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use od_core::{Bitrate, CanId, Frame, Instant};

use super::control::{self, node_name, Command, Selector};
use super::decode::{describe, fit, view_line, Known};
use super::devices::{bench, Registry};
use super::master::BenchMaster;
use super::options::{Options, UNCONFIGURED};
#[cfg(target_os = "linux")]
use super::socketcan::CanSocket;
use super::socketcand::{self as sc, Refused, Request};
use crate::segment::Segment;

/// Frames one client may have waiting for its bus; beyond them its reader stops reading.
pub const CLIENT_FRAMES: usize = 32;
/// How long a writer that fell behind waits before its next batch.
const BATCH: Duration = Duration::from_millis(10);
/// A batch this long (messages) means the writer fell behind.
const BEHIND: usize = 4;
/// Bytes of messages waiting for one client at most (about two seconds of a full 1 Mbit/s
/// bus); a client that does not read loses the frames beyond them.
pub const CLIENT_BYTES: usize = 256 * 1024;
/// Events (joins, leaves, wake-ups) waiting for the main loop at most.
const EVENTS: usize = 1024;
/// How far the bus may catch up when the main loop woke late (sleep granularity), so that
/// the bus carries its bit rate on average, never more.
const CATCH_UP_US: u64 = 2_000;

/// The time a frame takes on a bus at `rate`, in µs: its bits with the worst-case stuff bits
/// (one per four bits from SOF to the CRC) and the 3-bit intermission (D-SIM-12).
pub fn frame_time(frame: &Frame, rate: Bitrate) -> u64 {
    let data = if frame.rtr { 0 } else { 8 * u64::from(frame.len) };
    // SOF, arbitration, control, data, CRC: the part bit stuffing applies to.
    let stuffed = match frame.id {
        CanId::Std(_) => 34 + data,
        CanId::Ext(_) => 54 + data,
    };
    // CRC delimiter, ACK slot and delimiter, EOF, intermission.
    let bits = stuffed + (stuffed - 1) / 4 + 13;
    (bits * 1000).div_ceil(u64::from(rate.kbit()))
}

/// A bus of the simulator.
struct SimBus {
    name: String,
    rate: Bitrate,
    segment: Segment,
    labels: Vec<String>,
    /// What each node showed last (LEDs, screen).
    panels: Vec<Option<String>>,
    /// Each node's count of outputs its outbox dropped, as the view showed it last (D-ARCH-3).
    lost: Vec<u32>,
    /// Until when (µs since start) the bus carries the frames it was given.
    busy_until: u64,
    /// The client served last, for the round robin.
    turn: usize,
}

/// What client threads tell the main loop.
enum Event {
    /// Client `id` (shown as `label`) joins `bus`: its frames come through `frames`, the bus's
    /// go out through `out`; `dropped` counts the malformed messages its reader dropped.
    Join { id: usize, bus: usize, out: Sink, frames: Receiver<Frame>, dropped: Arc<AtomicU64>, label: String },
    /// A client queued a frame.
    Wake,
    /// Client `id` is gone.
    Left { id: usize },
    /// A command of the control port.
    Control(control::Request),
}

/// Builds the buses of `opts` and runs until the listener fails. Errors in the options or
/// devices are returned before anything runs.
pub fn run(opts: &Options) -> Result<(), String> {
    let specs = if opts.devices.is_empty() { bench() } else { opts.devices.clone() };
    let registry = Registry::new(opts.state_dir.as_deref());
    let mut buses: Vec<SimBus> = Vec::new();
    let mut ordinals: HashMap<(String, &'static str), usize> = HashMap::new();
    for (position, spec) in specs.iter().enumerate() {
        let ordinal = ordinals.entry((spec.bus.clone(), spec.kind.name())).or_insert(0);
        *ordinal += 1;
        for plan in registry.build(spec, *ordinal, position)? {
            let b = match buses.iter().position(|b| b.name == plan.bus) {
                Some(b) => b,
                None => {
                    let rate = opts.bitrate(&plan.bus);
                    buses.push(SimBus {
                        name: plan.bus.clone(),
                        rate,
                        segment: Segment::new(),
                        labels: Vec::new(),
                        panels: Vec::new(),
                        lost: Vec::new(),
                        busy_until: 0,
                        turn: 0,
                    });
                    buses.len() - 1
                }
            };
            buses[b].segment.add_with_flash(plan.params, plan.boot);
            buses[b].labels.push(plan.label);
            buses[b].panels.push(None);
            buses[b].lost.push(0);
        }
    }
    check_buses(opts, &buses)?;
    for hint in rate_hints(&buses) {
        eprintln!("sim: {hint}");
    }
    // Bound before the socketcand port: once that answers, so does the control port.
    let control = match &opts.control {
        Some(addr) => Some(TcpListener::bind(addr).map_err(|e| format!("--control {addr}: {e}"))?),
        None => None,
    };
    let listener = TcpListener::bind(&opts.listen).map_err(|e| format!("--listen {}: {e}", opts.listen))?;
    let trace = match &opts.trace {
        Some(p) => Some(BufWriter::new(File::create(p).map_err(|e| format!("--trace {}: {e}", p.display()))?)),
        None => None,
    };
    if !opts.quiet {
        println!("sim: socketcand on {} (rawmode)", listener.local_addr().map_err(|e| e.to_string())?);
        if let Some(c) = &control {
            println!("sim: control port on {}", c.local_addr().map_err(|e| e.to_string())?);
        }
        for b in &buses {
            println!("  {} at {} kbit/s: {}", b.name, b.rate.kbit(), b.labels.join(", "));
        }
    }
    let names: Arc<Vec<String>> = Arc::new(buses.iter().map(|b| b.name.clone()).collect());
    let (tx, rx) = sync_channel(EVENTS);
    for (k, (bus, iface)) in opts.socketcan.iter().enumerate() {
        let b = names.iter().position(|n| n == bus).ok_or(format!("--socketcan {bus}={iface}: no device on {bus}"))?;
        bridge(BRIDGE_IDS + k, b, iface, tx.clone()).map_err(|e| format!("--socketcan {bus}={iface}: {e}"))?;
    }
    if let Some(c) = control {
        let tx = tx.clone();
        thread::spawn(move || control::serve(c, move |r| tx.send(Event::Control(r)).is_ok()));
    }
    thread::spawn(move || accept(listener, names, tx));
    let master = opts.devices.is_empty().then(|| {
        let nodes: Vec<(usize, u8)> = buses
            .iter()
            .enumerate()
            .flat_map(|(b, bus)| (0..bus.segment.len()).map(move |i| (b, bus.segment.core(i))))
            // A CANopen master: the J1939 nodes (no SDO server, 1200h) are left alone.
            .filter(|(_, core)| core.od.pos(0x1200, 1).is_some())
            .map(|(b, core)| (b, core.node_id))
            .collect();
        let master = BenchMaster::new(&nodes);
        // The bench's display shows the SGH10's position (D-SIM-19).
        let find = |label: &str| {
            buses.iter().enumerate().find_map(|(b, bus)| {
                let i = bus.labels.iter().position(|l| l == label)?;
                Some((b, bus.segment.core(i).node_id))
            })
        };
        match (find("AP10T"), find("SGH10")) {
            (Some((b, display)), Some((s, source))) if b == s => master.with_display(b, display, source),
            _ => master,
        }
    });
    Sim {
        buses,
        clients: Vec::new(),
        trace,
        quiet: opts.quiet,
        start: std::time::Instant::now(),
        epoch: SystemTime::now(),
        master,
    }
    .main_loop(rx);
    Ok(())
}

/// What the command line must not ask for: a `--bitrate` for a bus without devices, two nodes
/// of one bus on one node-ID, two nodes of one bus with one LSS address (D-SIM-14, D-SIM-17).
fn check_buses(opts: &Options, buses: &[SimBus]) -> Result<(), String> {
    for (bus, rate) in &opts.bitrates {
        if !buses.iter().any(|b| &b.name == bus) {
            return Err(format!("--bitrate {bus}={}: no device on {bus}", rate.kbit()));
        }
    }
    for bus in buses {
        let seg = &bus.segment;
        for i in 0..seg.len() {
            for j in 0..i {
                let (a, b) = (seg.core(j), seg.core(i));
                let who = format!("{} and {} on {}", bus.labels[j], bus.labels[i], bus.name);
                // J1939 nodes (no SDO server object 1200h) may share a configured address:
                // address claiming separates them (D-J1939-24).
                let canopen = |c: &od_core::node::Core| c.od.pos(0x1200, 1).is_some();
                if a.node_id == b.node_id && a.node_id != UNCONFIGURED && canopen(a) && canopen(b) {
                    return Err(format!(
                        "{who} both have node-ID {}: give each device its own node= (or node=unconfigured \
                         to set it over LSS)",
                        a.node_id
                    ));
                }
                let lss = |c: &od_core::node::Core| (1..=4).map(|s| c.od.value(0x1018, s)).collect::<Vec<_>>();
                if lss(a) == lss(b) {
                    return Err(format!(
                        "{who} have the same LSS address (1018h, serial number {:X}h): give them different serial=",
                        a.od.value(0x1018, 4).unwrap_or(0)
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A hint for each bus where no node runs at the bus's bit rate: the bus then stays silent.
fn rate_hints(buses: &[SimBus]) -> Vec<String> {
    let mut hints = Vec::new();
    for bus in buses {
        let seg = &bus.segment;
        if (0..seg.len()).any(|i| seg.bitrate(i) == bus.rate) {
            continue;
        }
        let mut theirs: Vec<u32> = (0..seg.len()).map(|i| seg.bitrate(i).kbit()).collect();
        theirs.sort_unstable();
        theirs.dedup();
        let theirs: Vec<String> = theirs.iter().map(|k| k.to_string()).collect();
        hints.push(format!(
            "hint: no node on {} runs at its {} kbit/s (they run at {} kbit/s), so none sees or sends a frame; \
             --bitrate {}={} puts the bus at theirs",
            bus.name,
            bus.rate.kbit(),
            theirs.join(", "),
            bus.name,
            theirs[0]
        ));
    }
    hints
}

/// What goes to one socketcand client: messages bounded by their bytes.
struct TextQueue {
    state: Mutex<Queued>,
    changed: Condvar,
}

struct Queued {
    items: VecDeque<Item>,
    bytes: usize,
    closed: bool,
}

enum Item {
    Text(String),
    /// The writer holds the next messages back a moment.
    Pause,
}

impl TextQueue {
    fn new() -> TextQueue {
        TextQueue {
            state: Mutex::new(Queued { items: VecDeque::new(), bytes: 0, closed: false }),
            changed: Condvar::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Queued> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queues `text` if it fits: `Some(false)` if it does not (dropped), `None` if the client
    /// is gone.
    fn try_push(&self, text: String) -> Option<bool> {
        let mut q = self.lock();
        if q.closed {
            return None;
        }
        if q.bytes + text.len() > CLIENT_BYTES {
            return Some(false);
        }
        q.bytes += text.len();
        q.items.push_back(Item::Text(text));
        // The writer waits only on an empty queue: waking it for every frame (a system call
        // per frame and client) was most of the main loop's time with 200 clients.
        if q.items.len() == 1 {
            self.changed.notify_all();
        }
        Some(true)
    }

    /// Queues `item`, waiting for room; false if the client is gone.
    fn push_wait(&self, item: Item) -> bool {
        let len = match &item {
            Item::Text(t) => t.len(),
            Item::Pause => 0,
        };
        let mut q = self.lock();
        while !q.closed && !q.items.is_empty() && q.bytes + len > CLIENT_BYTES {
            q = self.changed.wait(q).unwrap_or_else(|e| e.into_inner());
        }
        if q.closed {
            return false;
        }
        q.bytes += len;
        q.items.push_back(item);
        self.changed.notify_all();
        true
    }

    /// Queues `item` now, whatever the queue holds (a short answer of the server's own).
    fn push_now(&self, item: Item) {
        let mut q = self.lock();
        if let Item::Text(t) = &item {
            q.bytes += t.len();
        }
        q.items.push_back(item);
        self.changed.notify_all();
    }

    /// Everything queued, in order, once there is something; `None` once closed and empty.
    /// The writer sends a batch while the queue fills again: at most twice the bound is in
    /// the simulator per client (a batch being written, a full queue).
    fn take_all(&self) -> Option<VecDeque<Item>> {
        let mut q = self.lock();
        loop {
            if !q.items.is_empty() {
                let items = std::mem::take(&mut q.items);
                q.bytes = 0;
                self.changed.notify_all();
                return Some(items);
            }
            if q.closed {
                return None;
            }
            q = self.changed.wait(q).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// No more items are taken; the writer sends what is queued and stops.
    fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    /// Nothing is sent any more (the connection failed).
    fn abandon(&self) {
        let mut q = self.lock();
        q.closed = true;
        q.items.clear();
        q.bytes = 0;
        self.changed.notify_all();
    }
}

/// Where a client's frames go.
enum Sink {
    /// A socketcand client's writer: the text to send.
    Text(Arc<TextQueue>),
    /// A SocketCAN bridge's writer: the frame (bounded; a full queue drops the frame).
    Can(SyncSender<Frame>),
}

struct Client {
    id: usize,
    bus: usize,
    out: Sink,
    label: String,
    frames: Receiver<Frame>,
    /// The client's next frame, taken from `frames`, waiting for the bus.
    pending: Option<Frame>,
    /// Malformed messages its reader dropped.
    dropped: Arc<AtomicU64>,
    /// Frames it did not get because it did not read.
    undelivered: u64,
    /// (dropped, undelivered) as the view showed them last, and when.
    shown: (u64, u64),
    shown_at: std::time::Instant,
}

/// The first client number of SocketCAN bridges (socketcand clients count from 1).
const BRIDGE_IDS: usize = 1 << 30;

struct Sim {
    buses: Vec<SimBus>,
    clients: Vec<Client>,
    trace: Option<BufWriter<File>>,
    quiet: bool,
    start: std::time::Instant,
    epoch: SystemTime,
    master: Option<BenchMaster>,
}

/// Who sent a frame, for the view.
#[derive(Clone, Copy, PartialEq)]
enum From {
    Node,
    Client(usize),
    Master,
}

impl Sim {
    fn now(&self) -> Instant {
        Instant::from_micros(self.start.elapsed().as_micros() as u64)
    }

    fn main_loop(mut self, rx: Receiver<Event>) {
        loop {
            let now = self.now();
            if let Some(m) = &mut self.master {
                for (b, frame) in m.due(now.as_millis()) {
                    self.transmit(b, &frame, From::Master, now);
                }
            }
            for b in 0..self.buses.len() {
                self.run_nodes(b, now);
                self.show_panels(b);
            }
            self.serve_clients(now);
            self.show_counts();
            let master = self.master.as_ref().map(|m| Instant::from_millis(m.deadline()));
            // A bus with a client frame waiting is due when it is free again.
            let busy = self.buses.iter().enumerate().filter_map(|(b, bus)| {
                self.clients.iter().any(|c| c.bus == b && c.pending.is_some()).then_some(bus.busy_until)
            });
            let next = self
                .buses
                .iter()
                .filter_map(|b| b.segment.next_deadline())
                .chain(master)
                .chain(busy.map(Instant::from_micros))
                .min();
            let wait = match next {
                Some(t) => Duration::from_micros(t.as_micros().saturating_sub(self.now().as_micros())),
                None => Duration::from_millis(100),
            };
            match rx.recv_timeout(wait.min(Duration::from_millis(100))) {
                Ok(ev) => self.event(ev),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            while let Ok(ev) = rx.try_recv() {
                self.event(ev);
            }
        }
    }

    fn event(&mut self, ev: Event) {
        match ev {
            Event::Join { id, bus, out, frames, dropped, label } => {
                if let Sink::Text(q) = &out {
                    // The answer to `< rawmode >`. python-can reads it with one recv and
                    // compares it whole: the writer holds frames back a moment so they do
                    // not arrive glued to it (none is lost: they wait in the queue).
                    q.push_now(Item::Text(sc::OK.into()));
                    q.push_now(Item::Pause);
                }
                if !self.quiet {
                    println!("-- {label} joins {}", self.buses[bus].name);
                }
                let shown_at = std::time::Instant::now();
                self.clients.push(Client {
                    id,
                    bus,
                    out,
                    label,
                    frames,
                    pending: None,
                    dropped,
                    undelivered: 0,
                    shown: (0, 0),
                    shown_at,
                })
            }
            Event::Wake => {}
            Event::Left { id } => {
                if let Some(c) = self.clients.iter().find(|c| c.id == id) {
                    if !self.quiet {
                        println!("-- {} leaves {}", c.label, self.buses[c.bus].name);
                    }
                }
                self.clients.retain(|c| c.id != id)
            }
            Event::Control(control::Request { command, reply }) => {
                let answer = match self.control(command) {
                    Ok(text) if text.is_empty() => "ok".to_string(),
                    Ok(text) => format!("ok {text}"),
                    Err(e) => format!("error {e}"),
                };
                let _ = reply.send(answer);
            }
        }
    }

    /// The (bus, node) `sel` names: exactly one.
    fn find(&self, sel: &Selector) -> Result<(usize, usize), String> {
        let mut found = Vec::new();
        for (b, bus) in self.buses.iter().enumerate() {
            for i in 0..bus.segment.len() {
                if sel.matches(&bus.name, &bus.labels[i], bus.segment.core(i).node_id) {
                    found.push((b, i));
                }
            }
        }
        match found.as_slice() {
            [one] => Ok(*one),
            [] => Err(format!("no device {sel} (see list)")),
            more => {
                let names: Vec<String> = more.iter().map(|&(b, i)| self.node_name(b, i)).collect();
                Err(format!("{sel} names several devices: {}", names.join(" ")))
            }
        }
    }

    fn node_name(&self, b: usize, i: usize) -> String {
        let bus = &self.buses[b];
        node_name(&bus.name, &bus.labels[i], bus.segment.core(i).node_id)
    }

    /// Carries out a command of the control port: the reply's text after `ok`, or the error.
    /// What it makes the nodes send goes out at once, ahead of later bus traffic.
    fn control(&mut self, command: Command) -> Result<String, String> {
        let now = self.now();
        match command {
            Command::List => {
                let names: Vec<String> = (0..self.buses.len())
                    .flat_map(|b| (0..self.buses[b].segment.len()).map(move |i| (b, i)))
                    .map(|(b, i)| self.node_name(b, i))
                    .collect();
                Ok(names.join(" "))
            }
            Command::Press { device, key } => {
                let (b, i) = self.find(&device)?;
                let name = self.node_name(b, i);
                let station = self.buses[b].segment.station(i);
                let display = station
                    .as_any_mut()
                    .and_then(|a| a.downcast_mut::<crate::ap10t::Display>())
                    .ok_or(format!("{name} has no keys"))?;
                // A press and its release at one instant: keys act on the press (D-AP-8).
                display.press(key, now);
                display.release(key, now);
                self.run_nodes(b, now);
                self.show_panels(b);
                Ok(String::new())
            }
            Command::Screen { device } => {
                let (b, i) = self.find(&device)?;
                let name = self.node_name(b, i);
                self.run_nodes(b, now);
                self.buses[b].segment.panel(i).ok_or(format!("{name} shows nothing"))
            }
            Command::Position { device, raw } => {
                let (b, i) = self.find(&device)?;
                let name = self.node_name(b, i);
                self.buses[b].segment.station(i).set_sensor(raw).map_err(|e| format!("{name}: {e}"))?;
                self.run_nodes(b, now);
                Ok(String::new())
            }
        }
    }

    /// Client frames onto their buses, one at a time while the bus is free, round robin.
    fn serve_clients(&mut self, now: Instant) {
        for b in 0..self.buses.len() {
            while self.buses[b].busy_until <= now.as_micros() {
                let Some(k) = self.next_client(b) else { break };
                let c = &mut self.clients[k];
                let (id, frame) = (c.id, c.pending.take().expect("next_client has a frame"));
                self.buses[b].turn = id;
                self.transmit(b, &frame, From::Client(id), now);
            }
            // Frames that wait for the busy bus set the next wake-up.
            self.take_frames(b);
        }
    }

    /// The client of bus `b` whose frame goes next: the first after the one served last.
    fn next_client(&mut self, b: usize) -> Option<usize> {
        self.take_frames(b);
        let turn = self.buses[b].turn;
        let waiting = || self.clients.iter().enumerate().filter(|(_, c)| c.bus == b && c.pending.is_some());
        waiting()
            .filter(|(_, c)| c.id > turn)
            .min_by_key(|(_, c)| c.id)
            .or_else(|| waiting().min_by_key(|(_, c)| c.id))
            .map(|(k, _)| k)
    }

    /// Each client of bus `b` without a frame in hand takes the next of its queue, if any.
    fn take_frames(&mut self, b: usize) {
        let mut gone = Vec::new();
        for c in self.clients.iter_mut().filter(|c| c.bus == b && c.pending.is_none()) {
            match c.frames.try_recv() {
                Ok(f) => c.pending = Some(f),
                Err(TryRecvError::Empty) => {}
                Err(TryRecvError::Disconnected) => gone.push(c.id),
            }
        }
        self.clients.retain(|c| c.pending.is_some() || !gone.contains(&c.id));
    }

    /// A frame from outside the nodes onto bus `b`; the nodes' answers follow at once.
    fn transmit(&mut self, b: usize, frame: &Frame, from: From, now: Instant) {
        self.show(b, frame, from, now);
        let bus = &mut self.buses[b];
        bus.segment.deliver(None, frame, bus.rate, now);
        self.run_nodes(b, now);
    }

    /// Polls the nodes of bus `b` that are due and carries out all their outputs (a node's
    /// outbox is drained after every frame it receives, as the firmware's loop does).
    fn run_nodes(&mut self, b: usize, now: Instant) {
        let mut sent = Vec::new();
        let bus = &mut self.buses[b];
        bus.segment.run_due(now, bus.rate, &mut |_, f| sent.push(*f));
        for f in sent {
            self.show(b, &f, From::Node, now);
        }
    }

    /// The nodes of bus `b` whose LEDs or screen changed: shown in the view.
    fn show_panels(&mut self, b: usize) {
        let width = terminal_width();
        let bus = &mut self.buses[b];
        for i in 0..bus.segment.len() {
            let panel = bus.segment.panel(i);
            if panel != bus.panels[i] {
                if let (Some(p), false) = (&panel, self.quiet) {
                    let line = format!("{:<5} {}#{} {p}", bus.name, bus.labels[i], bus.segment.core(i).node_id);
                    println!("{}", fit(&line, width));
                }
                bus.panels[i] = panel;
            }
            let lost = bus.segment.core(i).out.dropped();
            if lost != bus.lost[i] {
                if !self.quiet {
                    let line = format!(
                        "-- {}#{} on {}: {lost} outputs lost (outbox full)",
                        bus.labels[i],
                        bus.segment.core(i).node_id,
                        bus.name
                    );
                    println!("{}", fit(&line, width));
                }
                bus.lost[i] = lost;
            }
        }
    }

    /// Clients whose malformed messages or undelivered frames grew: shown at most once a
    /// second each.
    fn show_counts(&mut self) {
        let width = terminal_width();
        for c in &mut self.clients {
            let now = (c.dropped.load(Ordering::Relaxed), c.undelivered);
            if now != c.shown && c.shown_at.elapsed() >= Duration::from_secs(1) {
                if !self.quiet {
                    let line = format!(
                        "-- {} on {}: {} malformed messages dropped, {} frames not delivered (not reading)",
                        c.label, self.buses[c.bus].name, now.0, now.1
                    );
                    println!("{}", fit(&line, width));
                }
                c.shown = now;
                c.shown_at = std::time::Instant::now();
            }
        }
    }

    /// A frame on bus `b`: it occupies the bus, goes to the clients (but its sender), the
    /// trace and the view.
    fn show(&mut self, b: usize, frame: &Frame, from: From, now: Instant) {
        let bus = &mut self.buses[b];
        let t = now.as_micros();
        bus.busy_until = bus.busy_until.max(t.saturating_sub(CATCH_UP_US)) + frame_time(frame, bus.rate);
        let wall = self.epoch + self.start.elapsed();
        let micros = wall.duration_since(UNIX_EPOCH).map(|d| d.as_micros() as u64).unwrap_or(0);
        let msg = sc::frame_message(frame, micros);
        if let Some(m) = &mut self.master {
            m.heard(b, frame);
        }
        let who = match from {
            From::Node => String::new(),
            From::Client(id) => {
                format!("  ({})", self.clients.iter().find(|c| c.id == id).map_or("client", |c| c.label.as_str()))
            }
            From::Master => "  (bench master)".into(),
        };
        self.clients.retain_mut(|c| {
            if c.bus != b || From::Client(c.id) == from {
                return true;
            }
            match &c.out {
                Sink::Text(out) => match out.try_push(msg.clone()) {
                    Some(true) => true,
                    Some(false) => {
                        c.undelivered += 1;
                        true
                    }
                    None => false,
                },
                Sink::Can(out) => !matches!(out.try_send(*frame), Err(TrySendError::Disconnected(_))),
            }
        });
        let bus = &self.buses[b];
        if let Some(t) = &mut self.trace {
            let id = sc::id_text(frame.id);
            // candump's log: a remote frame is `R`, followed by its DLC unless 0.
            let body = match (frame.rtr, frame.len) {
                (true, 0) => "R".to_string(),
                (true, n) => format!("R{n}"),
                (false, _) => frame.payload().iter().map(|x| format!("{x:02X}")).collect(),
            };
            let _ = writeln!(t, "({}.{:06}) {} {id}#{body}", micros / 1_000_000, micros % 1_000_000, bus.name);
            let _ = t.flush();
        }
        if !self.quiet {
            let known: Vec<Known> =
                (0..bus.segment.len()).map(|i| Known { label: &bus.labels[i], core: bus.segment.core(i) }).collect();
            let text = format!("{}{who}", describe(frame, &known));
            println!("{}", view_line(&bus.name, frame, &text, terminal_width()));
        }
    }
}

/// The width of the terminal the view goes to; `None` if it goes elsewhere (a file, a pipe),
/// where lines are not cut.
fn terminal_width() -> Option<usize> {
    #[cfg(unix)]
    {
        // SAFETY: TIOCGWINSZ writes one `winsize` into the value owned here.
        let mut ws: libc::winsize = unsafe { std::mem::zeroed() };
        let rc = unsafe { libc::ioctl(libc::STDOUT_FILENO, libc::TIOCGWINSZ, &mut ws) };
        if rc == 0 && ws.ws_col > 0 {
            return Some(ws.ws_col as usize);
        }
    }
    None
}

/// SocketCAN is Linux only.
#[cfg(not(target_os = "linux"))]
fn bridge(_: usize, _: usize, _: &str, _: SyncSender<Event>) -> std::io::Result<()> {
    Err(std::io::Error::new(std::io::ErrorKind::Unsupported, "SocketCAN exists on Linux only"))
}

/// Bridges bus `bus` to the SocketCAN interface `iface`: its frames go onto the bus like a
/// client's, and the bus's frames go out on it.
#[cfg(target_os = "linux")]
fn bridge(id: usize, bus: usize, iface: &str, tx: SyncSender<Event>) -> std::io::Result<()> {
    let rx_sock = CanSocket::open(iface)?;
    let tx_sock = rx_sock.try_clone()?;
    let (out, to_iface) = sync_channel::<Frame>(CLIENT_FRAMES);
    let (frames_tx, frames) = sync_channel::<Frame>(CLIENT_FRAMES);
    let join = Event::Join {
        id,
        bus,
        out: Sink::Can(out),
        frames,
        dropped: Arc::new(AtomicU64::new(0)),
        label: iface.to_string(),
    };
    tx.send(join).map_err(|_| std::io::Error::other("the simulator stopped"))?;
    thread::spawn(move || {
        for f in to_iface {
            // A full transmit queue (no one acknowledges on a real bus) drops the frame, as a
            // controller would retry it only so long.
            let _ = tx_sock.send(&f);
        }
    });
    thread::spawn(move || {
        while let Ok(frame) = rx_sock.recv() {
            if frames_tx.send(frame).is_err() {
                break;
            }
            let _ = tx.try_send(Event::Wake);
        }
        let _ = tx.send(Event::Left { id });
    });
    Ok(())
}

fn accept(listener: TcpListener, names: Arc<Vec<String>>, tx: SyncSender<Event>) {
    for (id, conn) in listener.incoming().enumerate() {
        let Ok(stream) = conn else { continue };
        let (names, tx) = (names.clone(), tx.clone());
        thread::spawn(move || serve(id + 1, stream, &names, tx));
    }
}

/// One client's session: the handshake, then its frames to the main loop.
fn serve(id: usize, stream: TcpStream, names: &[String], tx: SyncSender<Event>) {
    let _ = stream.set_nodelay(true);
    let Ok(mut writer) = stream.try_clone() else { return };
    let out = Arc::new(TextQueue::new());
    let queue = out.clone();
    thread::spawn(move || {
        // Each batch goes out in as few writes as its pauses allow. A writer that fell behind
        // (its last batch was long: a flood) waits BATCH before the next, so that a flood
        // reaches each of many clients in a write every BATCH rather than a write and a thread
        // wake-up per frame (with 200 clients the writers' wake-ups had starved the main loop:
        // 200 of 8,000 frames/s carried); a client that keeps up gets every batch at once.
        let mut text = String::new();
        let mut behind = false;
        'batches: while let Some(items) = {
            if behind {
                thread::sleep(BATCH);
            }
            queue.take_all()
        } {
            behind = items.len() >= BEHIND;
            for item in items {
                match item {
                    Item::Text(t) => text.push_str(&t),
                    Item::Pause => {
                        if !text.is_empty() && writer.write_all(text.as_bytes()).is_err() {
                            queue.abandon();
                            break 'batches;
                        }
                        text.clear();
                        thread::sleep(Duration::from_millis(50));
                    }
                }
            }
            if !text.is_empty() && writer.write_all(text.as_bytes()).is_err() {
                queue.abandon();
                break;
            }
            text.clear();
        }
        let _ = writer.shutdown(std::net::Shutdown::Both);
    });
    session(id, stream, names, &tx, &out);
    out.close();
    let _ = tx.send(Event::Left { id });
}

/// Reads and answers one client until it leaves (or asked for a bus there is not).
fn session(id: usize, mut reader: TcpStream, names: &[String], tx: &SyncSender<Event>, out: &Arc<TextQueue>) {
    let reply = |text: &str| out.push_wait(Item::Text(text.to_string()));
    if !reply(sc::HI) {
        return;
    }
    let dropped = Arc::new(AtomicU64::new(0));
    let mut buf = String::new();
    let mut chunk = [0u8; 1024];
    let mut bus: Option<usize> = None;
    let mut frames: Option<SyncSender<Frame>> = None;
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        buf.push_str(&String::from_utf8_lossy(&chunk[..n]));
        for msg in sc::split_messages(&mut buf) {
            let ok = match (msg.and_then(|m| sc::parse(&m)), bus, &frames) {
                (Err(Refused::Malformed(_)), ..) => {
                    dropped.fetch_add(1, Ordering::Relaxed);
                    true
                }
                (Err(Refused::Unknown), ..) => reply(sc::UNKNOWN_COMMAND),
                (Ok(Request::Echo), ..) => reply("< echo >"),
                (Ok(Request::Open(name)), None, _) => match names.iter().position(|n| *n == name) {
                    Some(b) => {
                        bus = Some(b);
                        reply(sc::OK)
                    }
                    // As socketcand: the error, then the connection ends.
                    None => {
                        reply(sc::COULD_NOT_OPEN);
                        return;
                    }
                },
                (Ok(Request::RawMode), Some(_), Some(_)) => reply(sc::OK),
                (Ok(Request::RawMode), Some(b), None) => {
                    // The main loop answers `< ok >` when the client has joined the bus, so
                    // every frame after the answer reaches it.
                    let (frames_tx, frames_rx) = sync_channel(CLIENT_FRAMES);
                    frames = Some(frames_tx);
                    let join = Event::Join {
                        id,
                        bus: b,
                        out: Sink::Text(out.clone()),
                        frames: frames_rx,
                        dropped: dropped.clone(),
                        label: format!("client {id}"),
                    };
                    if tx.send(join).is_err() {
                        return;
                    }
                    true
                }
                // Waits while the client's queue is full: the client waits (TCP), no one else.
                (Ok(Request::Send(frame)), Some(_), Some(f)) => {
                    if f.send(frame).is_err() {
                        return;
                    }
                    let _ = tx.try_send(Event::Wake);
                    true
                }
                // A second open, rawmode before open, a frame before rawmode: socketcand does
                // not know the command in that mode.
                (Ok(_), ..) => reply(sc::UNKNOWN_COMMAND),
            };
            if !ok {
                return;
            }
        }
    }
}
