//! The simulator in real time: one [`Segment`] per bus, driven at its nodes' deadlines by the
//! wall clock, served to socketcand clients over TCP, shown in a live view.
//!
//! Threads: one accepting connections, one reader and one writer per client; the main loop
//! owns every segment and learns of client frames through a channel, so a client can neither
//! block the buses nor another client.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc::{channel, sync_channel, Receiver, RecvTimeoutError, Sender, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use od_core::{Bitrate, Frame, Instant};

use super::decode::{describe, Known};
use super::devices::{bench, Registry};
use super::options::Options;
#[cfg(target_os = "linux")]
use super::socketcan::CanSocket;
use super::socketcand::{self as sc, Request};
use crate::segment::Segment;

/// A bus of the simulator.
struct SimBus {
    name: String,
    rate: Bitrate,
    segment: Segment,
    labels: Vec<String>,
    /// What each node showed last (LEDs, screen).
    panels: Vec<Option<String>>,
}

/// What client threads tell the main loop.
enum Event {
    /// Client `id` (shown as `label`) receives the frames of `bus` through `out` from now on.
    Join { id: usize, bus: usize, out: Sink, label: String },
    /// Client `id` sent `frame` on `bus`.
    Frame { id: usize, bus: usize, frame: Frame },
    /// Client `id` is gone.
    Left { id: usize },
}

/// Builds the buses of `opts` and runs until the listener fails. Errors in the options or
/// devices are returned before anything runs.
pub fn run(opts: &Options) -> Result<(), String> {
    let specs = if opts.devices.is_empty() { bench() } else { opts.devices.clone() };
    let registry = Registry::new(opts.state_dir.as_deref());
    let mut buses: Vec<SimBus> = Vec::new();
    let mut ordinals: HashMap<(String, &'static str), usize> = HashMap::new();
    for spec in &specs {
        let ordinal = ordinals.entry((spec.bus.clone(), spec.kind.name())).or_insert(0);
        *ordinal += 1;
        for plan in registry.build(spec, *ordinal)? {
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
                    });
                    buses.len() - 1
                }
            };
            buses[b].segment.add_with_flash(plan.params, plan.boot);
            buses[b].labels.push(plan.label);
            buses[b].panels.push(None);
        }
    }
    let listener = TcpListener::bind(&opts.listen).map_err(|e| format!("--listen {}: {e}", opts.listen))?;
    let trace = match &opts.trace {
        Some(p) => Some(BufWriter::new(File::create(p).map_err(|e| format!("--trace {}: {e}", p.display()))?)),
        None => None,
    };
    if !opts.quiet {
        println!("sim: socketcand on {} (rawmode)", listener.local_addr().map_err(|e| e.to_string())?);
        for b in &buses {
            println!("  {} at {} kbit/s: {}", b.name, b.rate.kbit(), b.labels.join(", "));
        }
    }
    let names: Arc<Vec<String>> = Arc::new(buses.iter().map(|b| b.name.clone()).collect());
    let (tx, rx) = channel();
    for (k, (bus, iface)) in opts.socketcan.iter().enumerate() {
        let b = names.iter().position(|n| n == bus).ok_or(format!("--socketcan {bus}={iface}: no device on {bus}"))?;
        bridge(BRIDGE_IDS + k, b, iface, tx.clone()).map_err(|e| format!("--socketcan {bus}={iface}: {e}"))?;
    }
    thread::spawn(move || accept(listener, names, tx));
    let master = opts.devices.is_empty().then(|| BenchMaster::new(&buses));
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

/// Where a client's frames go.
enum Sink {
    /// A socketcand client's writer: the text to send (bounded: a client that stops reading
    /// loses frames rather than growing the simulator's memory).
    Text(SyncSender<String>),
    /// A SocketCAN bridge's writer: the frame.
    Can(Sender<Frame>),
}

struct Client {
    id: usize,
    bus: usize,
    out: Sink,
    label: String,
}

/// Messages queued for one socketcand client at most (a second of a full 1 Mbit/s bus).
const CLIENT_QUEUE: usize = 16_384;

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

/// The ready-made bench's master on can0: it asks each node for its identity, sets its
/// heartbeat, starts it, and then sends SYNC periodically, so the bench shows every service.
struct BenchMaster {
    /// (time in ms, bus, frame), in time order.
    script: Vec<(u64, usize, Frame)>,
    next: usize,
    next_sync: u64,
}

/// The bench master's SYNC period.
const SYNC_MS: u64 = 1000;

impl BenchMaster {
    fn new(buses: &[SimBus]) -> BenchMaster {
        let mut script = Vec::new();
        let mut t = 500;
        for (b, bus) in buses.iter().enumerate() {
            for i in 0..bus.segment.len() {
                let id = bus.segment.core(i).node_id as u16;
                script.push((t, b, Frame::std(0x600 + id, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])));
                script.push((t + 100, b, Frame::std(0x600 + id, &[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0])));
                script.push((t + 200, b, Frame::std(0x000, &[0x01, id as u8])));
                t += 400;
            }
        }
        BenchMaster { script, next: 0, next_sync: t + 500 }
    }

    fn deadline(&self) -> u64 {
        self.script.get(self.next).map_or(self.next_sync, |s| s.0.min(self.next_sync))
    }

    /// The frames due at `ms`.
    fn due(&mut self, ms: u64) -> Vec<(usize, Frame)> {
        let mut out = Vec::new();
        while let Some(&(_, b, f)) = self.script.get(self.next).filter(|s| s.0 <= ms) {
            out.push((b, f));
            self.next += 1;
        }
        if ms >= self.next_sync {
            out.push((0, Frame::std(0x080, &[])));
            self.next_sync += SYNC_MS;
        }
        out
    }
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
                    self.show(b, &frame, From::Master);
                    let bus = &mut self.buses[b];
                    bus.segment.deliver(None, &frame, bus.rate, now);
                }
            }
            for b in 0..self.buses.len() {
                let mut sent = Vec::new();
                let bus = &mut self.buses[b];
                bus.segment.run_due(now, bus.rate, &mut |_, f| sent.push(*f));
                for f in sent {
                    self.show(b, &f, From::Node);
                }
                self.show_panels(b);
            }
            let master = self.master.as_ref().map(|m| Instant::from_millis(m.deadline()));
            let next = self.buses.iter().filter_map(|b| b.segment.next_deadline()).chain(master).min();
            let wait = match next {
                Some(t) => Duration::from_micros(t.as_micros().saturating_sub(self.now().as_micros())),
                None => Duration::from_millis(100),
            };
            match rx.recv_timeout(wait.min(Duration::from_millis(100))) {
                Ok(ev) => self.event(ev),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            // Take every event already queued before running the nodes again.
            while let Ok(ev) = rx.try_recv() {
                self.event(ev);
            }
        }
    }

    fn event(&mut self, ev: Event) {
        match ev {
            Event::Join { id, bus, out, label } => {
                if !self.quiet {
                    println!("-- {label} joins {}", self.buses[bus].name);
                }
                self.clients.push(Client { id, bus, out, label })
            }
            Event::Left { id } => {
                if let Some(c) = self.clients.iter().find(|c| c.id == id) {
                    if !self.quiet {
                        println!("-- {} leaves {}", c.label, self.buses[c.bus].name);
                    }
                }
                self.clients.retain(|c| c.id != id)
            }
            Event::Frame { id, bus, frame } => {
                let now = self.now();
                self.show(bus, &frame, From::Client(id));
                let b = &mut self.buses[bus];
                b.segment.deliver(None, &frame, b.rate, now);
            }
        }
    }

    /// The nodes of bus `b` whose LEDs or screen changed: shown in the view.
    fn show_panels(&mut self, b: usize) {
        let bus = &mut self.buses[b];
        for i in 0..bus.segment.len() {
            let panel = bus.segment.panel(i);
            if panel != bus.panels[i] {
                if let (Some(p), false) = (&panel, self.quiet) {
                    println!("{:<5} {}#{} {p}", bus.name, bus.labels[i], bus.segment.core(i).node_id);
                }
                bus.panels[i] = panel;
            }
        }
    }

    /// A frame on bus `b`: to the clients (but its sender), the trace and the view.
    fn show(&mut self, b: usize, frame: &Frame, from: From) {
        let wall = self.epoch + self.start.elapsed();
        let micros = wall.duration_since(UNIX_EPOCH).map(|d| d.as_micros() as u64).unwrap_or(0);
        let msg = sc::frame_message(frame, micros);
        let who = match from {
            From::Node => String::new(),
            From::Client(id) => {
                format!("  ({})", self.clients.iter().find(|c| c.id == id).map_or("client", |c| c.label.as_str()))
            }
            From::Master => "  (bench master)".into(),
        };
        self.clients.retain(|c| {
            c.bus != b
                || From::Client(c.id) == from
                || match &c.out {
                    Sink::Text(out) => !matches!(out.try_send(msg.clone()), Err(TrySendError::Disconnected(_))),
                    Sink::Can(out) => out.send(*frame).is_ok(),
                }
        });
        let bus = &self.buses[b];
        let data: String = frame.payload().iter().map(|x| format!("{x:02X}")).collect();
        if let Some(t) = &mut self.trace {
            let id = sc::id_text(frame.id);
            let body = if frame.rtr { "R".to_string() } else { data };
            let _ = writeln!(t, "({}.{:06}) {} {id}#{body}", micros / 1_000_000, micros % 1_000_000, bus.name);
            let _ = t.flush();
        }
        if !self.quiet {
            let known: Vec<Known> =
                (0..bus.segment.len()).map(|i| Known { label: &bus.labels[i], core: bus.segment.core(i) }).collect();
            let bytes: Vec<String> = frame.payload().iter().map(|x| format!("{x:02X}")).collect();
            println!(
                "{:<5} {:>8}   [{}]  {:<24} {}{who}",
                bus.name,
                sc::id_text(frame.id),
                frame.len,
                bytes.join(" "),
                describe(frame, &known)
            );
        }
    }
}

/// SocketCAN is Linux only.
#[cfg(not(target_os = "linux"))]
fn bridge(_: usize, _: usize, _: &str, _: Sender<Event>) -> std::io::Result<()> {
    Err(std::io::Error::new(std::io::ErrorKind::Unsupported, "SocketCAN exists on Linux only"))
}

/// Bridges bus `bus` to the SocketCAN interface `iface`: its frames go onto the bus like a
/// client's, and the bus's frames go out on it.
#[cfg(target_os = "linux")]
fn bridge(id: usize, bus: usize, iface: &str, tx: Sender<Event>) -> std::io::Result<()> {
    let rx_sock = CanSocket::open(iface)?;
    let tx_sock = rx_sock.try_clone()?;
    let (out, frames) = channel::<Frame>();
    tx.send(Event::Join { id, bus, out: Sink::Can(out), label: iface.to_string() }).map_err(std::io::Error::other)?;
    thread::spawn(move || {
        for f in frames {
            // A full transmit queue (no one acknowledges on a real bus) drops the frame, as a
            // controller would retry it only so long.
            let _ = tx_sock.send(&f);
        }
    });
    thread::spawn(move || {
        while let Ok(frame) = rx_sock.recv() {
            if tx.send(Event::Frame { id, bus, frame }).is_err() {
                break;
            }
        }
        let _ = tx.send(Event::Left { id });
    });
    Ok(())
}

fn accept(listener: TcpListener, names: Arc<Vec<String>>, tx: Sender<Event>) {
    for (id, conn) in listener.incoming().enumerate() {
        let Ok(stream) = conn else { continue };
        let (names, tx) = (names.clone(), tx.clone());
        thread::spawn(move || serve(id + 1, stream, &names, tx));
    }
}

/// One client's session: the handshake, then its frames to the main loop.
fn serve(id: usize, stream: TcpStream, names: &[String], tx: Sender<Event>) {
    let _ = stream.set_nodelay(true);
    let Ok(mut writer) = stream.try_clone() else { return };
    let (out, out_rx) = sync_channel::<String>(CLIENT_QUEUE);
    thread::spawn(move || {
        for msg in out_rx {
            if msg.is_empty() {
                thread::sleep(Duration::from_millis(50));
            } else if writer.write_all(msg.as_bytes()).is_err() {
                break;
            }
        }
        let _ = writer.shutdown(std::net::Shutdown::Both);
    });
    let _ = out.send(sc::HI.into());
    let mut reader = stream;
    let mut buf = String::new();
    let mut chunk = [0u8; 1024];
    let mut bus: Option<usize> = None;
    let mut raw = false;
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        buf.push_str(&String::from_utf8_lossy(&chunk[..n]));
        for msg in sc::split_messages(&mut buf) {
            let reply = match msg.and_then(|m| sc::parse(&m)) {
                Err(e) => Some(sc::error_message(&e)),
                Ok(Request::Echo) => Some("< echo >".into()),
                Ok(Request::Open(name)) => match names.iter().position(|n| *n == name) {
                    _ if bus.is_some() => Some(sc::error_message("a bus is open already")),
                    Some(b) => {
                        bus = Some(b);
                        Some(sc::OK.into())
                    }
                    None => Some(sc::error_message(&format!("unknown bus {name}"))),
                },
                Ok(Request::RawMode) => match bus {
                    None => Some(sc::error_message("open a bus first")),
                    Some(_) if raw => Some(sc::OK.into()),
                    Some(b) => {
                        raw = true;
                        let _ = out.send(sc::OK.into());
                        // python-can reads the `< ok >` with one recv and compares it whole:
                        // the writer holds frames back a moment so they do not arrive glued
                        // to it (none is lost: they wait in the channel).
                        let _ = out.send(String::new());
                        let join =
                            Event::Join { id, bus: b, out: Sink::Text(out.clone()), label: format!("client {id}") };
                        if tx.send(join).is_err() {
                            return;
                        }
                        None
                    }
                },
                Ok(Request::Send(frame)) => match (bus, raw) {
                    (Some(b), true) => {
                        if tx.send(Event::Frame { id, bus: b, frame }).is_err() {
                            return;
                        }
                        None
                    }
                    _ => Some(sc::error_message("send needs rawmode")),
                },
            };
            if let Some(r) = reply {
                if out.send(r).is_err() {
                    break;
                }
            }
        }
    }
    let _ = tx.send(Event::Left { id });
}
