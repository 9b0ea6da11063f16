//! Encoders on the virtual bus: a node whose sensor the test moves.
//!
//! [`Sensed`] puts a CiA 406 encoder node on the [`crate::bus::Bus`] and samples its sensor every
//! [`Encoder::sample_period_us`] of virtual time, exactly as the firmware's sensor task does.
//! The test keeps a [`Sensor`] handle to the same sensor: it sets the raw reading, moves it at
//! a constant rate, makes it fail, and reports CAN-controller events, while the node is on the
//! bus.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use od_core::encoder::{Encoder, SensorFault};
use od_core::lss::Lss;
use od_core::nmt::NmtState;
use od_core::node::{BusEvent, CanopenDevice, Context, Core, Node, Output, RxIds};
use od_core::{DeviceStation, Frame, Instant};

use crate::bus::Station;

#[derive(Debug)]
struct State {
    /// Reading at `since`.
    base: i64,
    /// Counts per second from `since`.
    rate: i64,
    since: Instant,
    /// Last time the station saw (the sensor's "now" for set/move).
    now: Instant,
    fault: Option<SensorFault>,
    events: VecDeque<BusEvent>,
    samples: u64,
}

impl State {
    fn at(&self, t: Instant) -> i64 {
        let dt = t.micros_since(self.since) as i128;
        self.base + (self.rate as i128 * dt / 1_000_000) as i64
    }

    fn read(&self, t: Instant) -> Result<u32, SensorFault> {
        match self.fault {
            Some(f) => Err(f),
            None => u32::try_from(self.at(t)).map_err(|_| SensorFault::OutOfRange),
        }
    }

    fn rebase(&mut self) {
        self.base = self.at(self.now);
        self.since = self.now;
    }
}

/// The test's handle to a sensor: the raw reading the device's 600Ch defines (µm of wire on
/// the SGH encoders), as a function of virtual time. Clones share the sensor.
#[derive(Clone, Debug)]
pub struct Sensor(Rc<RefCell<State>>);

impl Sensor {
    /// A sensor reading `raw`, at rest.
    pub fn new(raw: u32) -> Sensor {
        Sensor(Rc::new(RefCell::new(State {
            base: raw as i64,
            rate: 0,
            since: Instant::ZERO,
            now: Instant::ZERO,
            fault: None,
            events: VecDeque::new(),
            samples: 0,
        })))
    }

    /// From now on the sensor reads `raw` (and rests).
    pub fn set(&self, raw: u32) {
        let mut s = self.0.borrow_mut();
        s.since = s.now;
        s.base = raw as i64;
        s.rate = 0;
    }

    /// From now on the reading changes by `per_second` counts per second (negative: falling),
    /// starting from the present reading.
    pub fn move_at(&self, per_second: i64) {
        let mut s = self.0.borrow_mut();
        s.rebase();
        s.rate = per_second;
    }

    /// The reading the sensor gives at `t` (ignoring a fault).
    pub fn reading_at(&self, t: Instant) -> i64 {
        self.0.borrow().at(t)
    }

    /// From now on the sensor reports `fault` instead of a reading.
    pub fn fail(&self, fault: SensorFault) {
        let mut s = self.0.borrow_mut();
        s.rebase();
        s.fault = Some(fault);
    }

    /// The fault is gone; the sensor reads again.
    pub fn heal(&self) {
        self.0.borrow_mut().fault = None;
    }

    /// The CAN controller reports `event` to the node at its next poll (run the bus with
    /// `advance(0)` to deliver it at once).
    pub fn bus_event(&self, event: BusEvent) {
        self.0.borrow_mut().events.push_back(event);
    }

    /// How many samples the node has taken.
    pub fn samples(&self) -> u64 {
        self.0.borrow().samples
    }
}

/// An encoder node, CANopen or J1939, with a sampled [`Sensor`], as a bus station.
pub struct SensedNode<N: DeviceStation> {
    pub(crate) node: N,
    sensor: Sensor,
    next_sample: Instant,
}

/// A CANopen node of encoder `E` with a sampled [`Sensor`].
pub type Sensed<E> = SensedNode<Node<E>>;

impl<N: DeviceStation> SensedNode<N>
where
    N::Device: Encoder,
{
    /// Node `node` fed by `sensor`; the first sample is taken when the node is first polled.
    pub fn new(node: N, sensor: Sensor) -> SensedNode<N> {
        SensedNode { node, sensor, next_sample: Instant::ZERO }
    }

    /// The node.
    pub fn node(&mut self) -> &mut N {
        &mut self.node
    }
}

impl<N: DeviceStation> od_core::Station for SensedNode<N>
where
    N::Device: Encoder,
{
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.sensor.tick(now);
        self.node.on_frame(frame, now);
    }

    fn poll(&mut self, now: Instant) {
        self.sensor.tick(now);
        while let Some(e) = self.sensor.next_event() {
            self.node.on_bus_event(e, now);
        }
        if self.next_sample <= now {
            let raw = self.sensor.sample(now);
            let (device, ctx) = self.node.split();
            device.on_sample(ctx, raw, now);
            let period = self.node.device().sample_period_us().max(1) as u64;
            while self.next_sample <= now {
                self.next_sample = self.next_sample.add_micros(period);
            }
        }
        self.node.poll(now);
    }

    fn next_deadline(&self) -> Option<Instant> {
        let mut next = self.next_sample;
        if let Some(t) = self.sensor.event_due() {
            next = next.min(t);
        }
        Some(match self.node.next_deadline() {
            Some(t) => t.min(next),
            None => next,
        })
    }

    fn next_output(&mut self) -> Option<Output> {
        self.node.next_output()
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

    fn rx_masks(&self) -> od_core::shell::RxMasks {
        self.node.rx_masks()
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

impl<E: Encoder + CanopenDevice> Station for Sensed<E> {
    fn nmt(&self) -> Option<NmtState> {
        Some(self.node.nmt_state())
    }
    fn lss(&self) -> Option<&Lss> {
        Some(self.node.lss())
    }
}

/// Expedited SDO request bytes: write `size` bytes (1, 2 or 4) of `value` to (index, sub).
pub fn download_request(index: u16, sub: u8, size: usize, value: u32) -> [u8; 8] {
    let cs = match size {
        1 => 0x2F,
        2 => 0x2B,
        3 => 0x27,
        _ => 0x23,
    };
    let i = index.to_le_bytes();
    let v = value.to_le_bytes();
    [cs, i[0], i[1], sub, v[0], v[1], v[2], v[3]]
}

/// Expedited SDO request bytes: read (index, sub).
pub fn upload_request(index: u16, sub: u8) -> [u8; 8] {
    let i = index.to_le_bytes();
    [0x40, i[0], i[1], sub, 0, 0, 0, 0]
}

/// Sends the SDO `request` to node `node` and returns the frames the bus carried before the
/// server's answer (EMCYs the request raised) and the answer (the frame on 580h + node-ID).
pub fn sdo_exchange(bus: &mut crate::bus::Bus, node: u8, request: [u8; 8]) -> (Vec<Frame>, [u8; 8]) {
    bus.send(Frame::std(0x600 + node as u16, &request));
    let mut before = Vec::new();
    while let Some(seen) = bus.recv() {
        if seen.frame.id == od_core::CanId::Std(0x580 + node as u16) {
            let mut data = [0u8; 8];
            data.copy_from_slice(seen.frame.payload());
            return (before, data);
        }
        before.push(seen.frame);
    }
    panic!("no SDO answer from node {node} to {request:02X?}");
}

/// Writes by expedited SDO and checks the acknowledgement; returns the frames the node sent
/// before it (EMCYs the write raised).
#[track_caller]
pub fn sdo_write(bus: &mut crate::bus::Bus, node: u8, index: u16, sub: u8, size: usize, value: u32) -> Vec<Frame> {
    let (before, answer) = sdo_exchange(bus, node, download_request(index, sub, size, value));
    let i = index.to_le_bytes();
    assert_eq!(answer, [0x60, i[0], i[1], sub, 0, 0, 0, 0], "write {index:04X}h.{sub:02X} = {value:#X}");
    before
}

/// Writes by expedited SDO and expects the abort `code`.
#[track_caller]
pub fn sdo_write_abort(bus: &mut crate::bus::Bus, node: u8, index: u16, sub: u8, size: usize, value: u32, code: u32) {
    let (_, answer) = sdo_exchange(bus, node, download_request(index, sub, size, value));
    let i = index.to_le_bytes();
    let c = code.to_le_bytes();
    assert_eq!(answer, [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]], "write {index:04X}h.{sub:02X} = {value:#X}");
}

/// Reads by expedited SDO; returns the value (zero-extended).
#[track_caller]
pub fn sdo_read(bus: &mut crate::bus::Bus, node: u8, index: u16, sub: u8) -> u32 {
    let (_, answer) = sdo_exchange(bus, node, upload_request(index, sub));
    let i = index.to_le_bytes();
    assert_eq!(
        (answer[0] & 0xF3, answer[1], answer[2], answer[3]),
        (0x43, i[0], i[1], sub),
        "read {index:04X}h.{sub:02X}: {answer:02X?}"
    );
    let n = 4 - ((answer[0] >> 2) & 3) as usize;
    let mut v = [0u8; 4];
    v[..n].copy_from_slice(&answer[4..4 + n]);
    u32::from_le_bytes(v)
}

/// Writes `value` to (index, sub) of a node off the bus, through the dictionary access path
/// as the SDO server does (checks, hooks, links, then the value), in any NMT state: for
/// property tests that drive a device directly.
pub fn direct_write<E: Encoder + CanopenDevice>(
    node: &mut Node<E>,
    index: u16,
    sub: u8,
    value: u32,
    now: Instant,
) -> Result<(), od_core::Abort> {
    let core = node.context();
    let pos = core.od.find(index, sub)?;
    let size = core.od.entry(pos).dtype.size();
    node.write(index, sub, &value.to_le_bytes()[..size], now).map(|_| ())
}

/// The value of (index, sub) as its type reads it (sign-extended for INTEGERn).
pub fn value(core: &Core, index: u16, sub: u8) -> i64 {
    let pos = core.od.pos(index, sub).unwrap_or_else(|| panic!("no {index:04X}h.{sub:02X}"));
    core.od.entry(pos).dtype.to_i64(core.od.get(pos))
}

/// What [`SensedNode`] does with a [`Sensor`].
impl Sensor {
    /// The station saw `now`.
    pub(crate) fn tick(&self, now: Instant) {
        self.0.borrow_mut().now = now;
    }

    /// The next CAN controller event waiting for the node.
    pub(crate) fn next_event(&self) -> Option<BusEvent> {
        self.0.borrow_mut().events.pop_front()
    }

    /// One sample at `now`.
    pub(crate) fn sample(&self, now: Instant) -> Result<u32, SensorFault> {
        let mut s = self.0.borrow_mut();
        s.samples += 1;
        s.read(now)
    }

    /// When the station must run for a waiting event, if any.
    pub(crate) fn event_due(&self) -> Option<Instant> {
        let s = self.0.borrow();
        (!s.events.is_empty()).then_some(s.now)
    }
}
