//! Bus faults and abuse with the reactions the manuals prescribe, on every encoder kind (SGH10,
//! SGH50 single and redundant, WV5800M), each followed by the proof that the node answers
//! normally afterwards (SDO read of 1000h, heartbeat on time, NMT start and its TPDO):
//!
//! - error passive and back, bus-off and its recovery (manuals' EMCY table: 8120h "bus status
//!   changed over to the error passive mode", 8140h "recovered from bus off", 0000h "cause of
//!   the error removed"; 1001h bit 4 "communication error (passive or bus-off)"; the WV5800M's
//!   CAN Err LED: single flash at the warning limit, on at bus-off);
//! - protocol errors ranked in 5000h ("sorted by frequency", 0..4);
//! - a babbling node on the node's own identifiers;
//! - an SDO client that vanishes mid-transfer (abort 05040000h after the 1 s timeout, D-SDO-3);
//! - a SYNC flood, an NMT reset storm, LSS traffic in the middle of an SDO transfer.

use std::cell::Cell;
use std::rc::Rc;

use od_core::devices::{sgh10, sgh50, wv5800m};
use od_core::encoder::Encoder;
use od_core::led::{LedState, Leds};
use od_core::lss::Lss;
use od_core::node::{BusEvent, CanError, CanopenDevice, Core, Node, Output};
use od_core::shell::RxIds;
use od_core::{Bitrate, CanId, Frame, Instant, NmtState};
use tests_host::bus::{Bus, Sender, Station};
use tests_host::encoder::{download_request, sdo_exchange, sdo_read, sdo_write, upload_request, Sensed, Sensor};

/// A WV5800M station that keeps what its LEDs show after every call.
struct WithLeds {
    inner: Sensed<wv5800m::Wv5800m>,
    leds: Rc<Cell<Option<Leds>>>,
}

impl WithLeds {
    fn refresh(&mut self) {
        self.leds.set(Some(self.inner.node().device().leds()));
    }
}

impl od_core::Station for WithLeds {
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.inner.on_frame(frame, now);
        self.refresh();
    }
    fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
        self.inner.on_bus_event(event, now);
        self.refresh();
    }
    fn poll(&mut self, now: Instant) {
        self.inner.poll(now);
        self.refresh();
    }
    fn next_deadline(&self) -> Option<Instant> {
        self.inner.next_deadline()
    }
    fn next_output(&mut self) -> Option<Output> {
        self.inner.next_output()
    }
    fn store_done(&mut self, result: Result<(), ()>, now: Instant) {
        self.inner.store_done(result, now)
    }
    fn rx_ids(&self) -> RxIds {
        self.inner.rx_ids()
    }
    fn rx_ids_generation(&self) -> u32 {
        self.inner.rx_ids_generation()
    }
    fn context(&self) -> &Core {
        self.inner.context()
    }
}

impl Station for WithLeds {
    fn nmt(&self) -> Option<NmtState> {
        Station::nmt(&self.inner)
    }
    fn lss(&self) -> Option<&Lss> {
        Station::lss(&self.inner)
    }
}

/// One device under test on its own bus: node-ID `id`, the sensor handle, its LEDs if it has
/// them, and for the redundant SGH50 the second encoder (`id + 1`) beside it.
struct Dut {
    name: &'static str,
    bus: Bus,
    sensor: Sensor,
    id: u8,
    leds: Option<Rc<Cell<Option<Leds>>>>,
    twin: Option<u8>,
    device_type: u32,
}

fn sensed<E: Encoder + CanopenDevice + 'static>(device: E, id: u8, raw: u32) -> (Sensed<E>, Sensor) {
    let sensor = Sensor::new(raw);
    (Sensed::new(Node::new(device, id, Bitrate::K500), sensor.clone()), sensor)
}

/// Every kind, booted, heartbeat 100 ms.
fn duts() -> Vec<Dut> {
    let mut out = Vec::new();
    let mut bus = Bus::new();
    let (s, sensor) = sensed(sgh10::Sgh10::new(sgh10::Variant::Sgh10), 1, 51_000);
    bus.add(s);
    out.push(Dut { name: "SGH10", bus, sensor, id: 1, leds: None, twin: None, device_type: 0x000A_0196 });
    let mut bus = Bus::new();
    let (s, sensor) = sensed(sgh50::Sgh50::new(sgh50::Variant::Single), 3, 51_000);
    bus.add(s);
    out.push(Dut { name: "SGH50", bus, sensor, id: 3, leds: None, twin: None, device_type: 0x000A_0196 });
    let mut bus = Bus::new();
    let (a, sensor) = sensed(sgh50::Sgh50::new(sgh50::Variant::Redundant(sgh50::Channel::First)), 4, 51_000);
    let (b, _) = sensed(sgh50::Sgh50::new(sgh50::Variant::Redundant(sgh50::Channel::Second)), 5, 51_000);
    bus.add(a);
    bus.add(b);
    out.push(Dut { name: "SGH50 redundant", bus, sensor, id: 4, leds: None, twin: Some(5), device_type: 0x000A_0196 });
    let mut bus = Bus::new();
    let variant = wv5800m::Variant { model: wv5800m::Model::Wv, turns: wv5800m::Turns::Multi12 };
    let (inner, sensor) = sensed(wv5800m::Wv5800m::new(variant), 6, 5000);
    let leds = Rc::new(Cell::new(None));
    bus.add(WithLeds { inner, leds: leds.clone() });
    out.push(Dut { name: "WV5800M", bus, sensor, id: 6, leds: Some(leds), twin: None, device_type: 0x0002_0196 });
    for d in &mut out {
        d.bus.advance(1);
        d.bus.drain();
        for id in [Some(d.id), d.twin].into_iter().flatten() {
            sdo_write(&mut d.bus, id, 0x1017, 0, 2, 100);
        }
        d.bus.drain();
    }
    out
}

fn emcy(code: u16, register: u8) -> [u8; 8] {
    let c = code.to_le_bytes();
    [c[0], c[1], register, 0, 0, 0, 0, 0]
}

impl Dut {
    fn event(&mut self, e: BusEvent) {
        self.sensor.bus_event(e);
        self.bus.advance(0);
    }

    /// The node's frames (not the twin's) since the last call, as (identifier, payload).
    fn frames(&mut self) -> Vec<(u16, Vec<u8>)> {
        let id = self.id as u16;
        self.bus
            .drain()
            .into_iter()
            .filter(|s| s.frame.id.raw() & 0x7F == id as u32 || s.frame.id == CanId::Std(0x7E4))
            .map(|s| (s.frame.id.raw() as u16, s.frame.payload().to_vec()))
            .collect()
    }

    /// Every frame on the bus in `(from, to]`, whoever took it from the inbox.
    fn log(&self, from: Instant, to: Instant) -> Vec<tests_host::bus::Seen> {
        self.bus.log.iter().filter(|s| s.at > from && s.at <= to).copied().collect()
    }

    fn red(&self) -> Option<LedState> {
        self.leds.as_ref().map(|l| l.get().expect("LEDs seen").red)
    }

    /// The node answers normally: SDO read of 1000h, heartbeats every 100 ms to the
    /// microsecond, NMT start and the cyclic TPDO; the twin likewise.
    #[track_caller]
    fn answers_normally(&mut self) {
        for id in [Some(self.id), self.twin].into_iter().flatten() {
            assert_eq!(sdo_read(&mut self.bus, id, 0x1000, 0), self.device_type, "{} node {id}", self.name);
        }
        self.bus.drain();
        let t0 = self.bus.now();
        self.bus.advance(1000);
        let beats: Vec<Instant> = self
            .bus
            .drain()
            .into_iter()
            .filter(|s| s.frame.id == CanId::Std(0x700 + self.id as u16))
            .map(|s| s.at)
            .collect();
        assert_eq!(beats.len(), 10, "{}: heartbeats in 1 s after {t0:?}", self.name);
        for w in beats.windows(2) {
            assert_eq!(w[1].micros_since(w[0]), 100_000, "{}: heartbeat period", self.name);
        }
        // OPERATIONAL with a 10 ms cyclic TPDO1.
        sdo_write(&mut self.bus, self.id, 0x1800, 5, 2, 10);
        self.bus.send(Frame::std(0, &[0x01, self.id]));
        self.bus.drain();
        self.bus.advance(100);
        let tpdos = self.bus.drain().into_iter().filter(|s| s.frame.id == CanId::Std(0x180 + self.id as u16)).count();
        assert!((10..=11).contains(&tpdos), "{}: {tpdos} TPDO1 in 100 ms", self.name);
        self.bus.send(Frame::std(0, &[0x80, self.id]));
        sdo_write(&mut self.bus, self.id, 0x1800, 5, 2, 0);
        self.bus.drain();
    }
}

#[test]
fn error_passive_and_back() {
    for mut d in duts() {
        let id = d.id as u16;
        if d.leds.is_some() {
            // WV5800M CAN Err LED: "warning limit reached" single flash (Table 4).
            d.event(BusEvent::ErrorCounters { rx: 0, tx: 96 });
            assert_eq!(d.red(), Some(LedState::SingleFlash));
        }
        d.event(BusEvent::ErrorPassive);
        assert_eq!(d.frames(), [(0x80 + id, emcy(0x8120, 0x11).to_vec())], "{}", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1001, 0), 0x11, "{}: 1001h bits 0 and 4", d.name);
        d.event(BusEvent::ErrorPassive);
        assert_eq!(d.frames(), [], "{}: once per error event", d.name);
        d.event(BusEvent::ErrorActive);
        d.event(BusEvent::ErrorCounters { rx: 0, tx: 0 });
        assert_eq!(d.frames(), [(0x80 + id, emcy(0x0000, 0x00).to_vec())], "{}", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1001, 0), 0, "{}", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1003, 1), 0x8120, "{}: history", d.name);
        if d.leds.is_some() {
            assert_eq!(d.red(), Some(LedState::Off));
        }
        d.answers_normally();
    }
}

#[test]
fn bus_off_and_recovery() {
    for mut d in duts() {
        let id = d.id as u16;
        d.event(BusEvent::ErrorPassive);
        d.event(BusEvent::BusOff);
        if d.leds.is_some() {
            assert_eq!(d.red(), Some(LedState::On), "WV5800M Table 4: bus off, CAN Err on");
        }
        // What the node queued before the controller went bus-off: the passive EMCY.
        assert_eq!(d.frames(), [(0x80 + id, emcy(0x8120, 0x11).to_vec())], "{}", d.name);
        d.event(BusEvent::BusOffRecovered);
        // The passive state ends with the recovery; then "recovered from bus off" and its
        // removal (the manuals' EMCY table).
        assert_eq!(
            d.frames(),
            [
                (0x80 + id, emcy(0x0000, 0x00).to_vec()),
                (0x80 + id, emcy(0x8140, 0x11).to_vec()),
                (0x80 + id, emcy(0x0000, 0x00).to_vec()),
            ],
            "{}",
            d.name
        );
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1001, 0), 0, "{}", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1003, 1), 0x8140, "{}: newest in the history", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1003, 2), 0x8120, "{}", d.name);
        if d.leds.is_some() {
            assert_eq!(d.red(), Some(LedState::Off));
        }
        d.answers_normally();
    }
}

#[test]
fn protocol_errors_are_ranked_in_5000h() {
    for mut d in duts() {
        // 5 stuff, 4 CRC, 3 form, 2 acknowledge, bit errors (not in 5000h) in between.
        let errors = [(CanError::Stuff, 5), (CanError::Crc, 4), (CanError::Form, 3), (CanError::Acknowledge, 2)];
        for (e, n) in errors {
            for _ in 0..n {
                d.event(BusEvent::ProtocolError(e));
                d.event(BusEvent::ProtocolError(CanError::Bit));
            }
        }
        // Byte 0 acknowledge, 1 form, 2 CRC, 3 stuff; 4 = most frequent.
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x5000, 0), 0x0403_0201, "{}", d.name);
        assert_eq!(d.frames().iter().filter(|(i, _)| *i & 0x780 == 0x80).count(), 0, "{}: no EMCY", d.name);
        d.answers_normally();
    }
}

/// Another node transmits on this node's identifiers at full load (8000 frames/s for 1 s):
/// the node ignores what is not addressed to it and keeps its heartbeat and SDO service.
#[test]
fn a_babbling_node_on_its_own_identifiers() {
    for mut d in duts() {
        let id = d.id as u16;
        let own = [0x180 + id, 0x280 + id, 0x80 + id, 0x580 + id, 0x700 + id, 0x7E4];
        let start = d.bus.now();
        let mut answered = 0;
        for k in 0..8000u64 {
            d.bus.advance_to(start.add_micros((k + 1) * 125));
            let cob = own[k as usize % own.len()];
            d.bus.send(Frame::std(cob, &(k as u32).to_le_bytes()));
            if k % 800 == 400 {
                let (_, a) = sdo_exchange(&mut d.bus, d.id, upload_request(0x1017, 0));
                assert_eq!(a, [0x4B, 0x17, 0x10, 0x00, 100, 0, 0, 0], "{}", d.name);
                answered += 1;
            }
        }
        assert_eq!(answered, 10);
        d.bus.advance_to(start.add_millis(1000));
        let seen: Vec<_> = d
            .log(start, d.bus.now())
            .into_iter()
            .filter(|s| s.from == Sender::Node(0) && s.frame.id != CanId::Std(0x580 + id))
            .collect();
        let beats = seen.iter().filter(|s| s.frame.id == CanId::Std(0x700 + id)).count();
        assert_eq!(beats, 10, "{}: heartbeats under the babble", d.name);
        assert!(seen.iter().all(|s| s.frame.id == CanId::Std(0x700 + id)), "{}: only heartbeats: {seen:02X?}", d.name);
        assert_eq!(d.bus.station(0).nmt(), Some(NmtState::PreOperational));
        d.answers_normally();
    }
}

#[test]
fn an_sdo_client_that_vanishes_mid_transfer_is_aborted_after_1_s() {
    for mut d in duts() {
        let rx = 0x580 + d.id as u16;
        // Segmented download of 1017h: initiated, one segment short of done, then silence.
        let (_, a) = sdo_exchange(&mut d.bus, d.id, [0x21, 0x17, 0x10, 0x00, 4, 0, 0, 0]);
        assert_eq!(a, [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0], "{}", d.name);
        let (_, a) = sdo_exchange(&mut d.bus, d.id, [0x0A, 0x07, 0x00, 0, 0, 0, 0, 0]);
        assert_eq!(a, [0x20, 0, 0, 0, 0, 0, 0, 0], "{}", d.name);
        let last = d.bus.now();
        d.bus.advance(2000);
        let aborts: Vec<_> = d.bus.drain().into_iter().filter(|s| s.frame.id == CanId::Std(rx)).collect();
        assert_eq!(aborts.len(), 1, "{}", d.name);
        assert_eq!(aborts[0].frame.payload(), [0x80, 0x17, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05], "{}", d.name);
        assert_eq!(aborts[0].at.micros_since(last), 1_000_000, "{}: after exactly 1 s", d.name);
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1017, 0), 100, "{}: nothing written", d.name);
        // Segmented upload of 1008h (the device name), abandoned after its initiation.
        let (_, a) = sdo_exchange(&mut d.bus, d.id, upload_request(0x1008, 0));
        assert_eq!(a[0], 0x41, "{}", d.name);
        d.bus.advance(1500);
        let aborts: Vec<_> = d.bus.drain().into_iter().filter(|s| s.frame.id == CanId::Std(rx)).collect();
        assert_eq!(aborts.len(), 1);
        assert_eq!(aborts[0].frame.payload(), [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
        // The server is idle: a segment request now is a protocol error, then a read works.
        let (_, a) = sdo_exchange(&mut d.bus, d.id, [0x70, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&a[4..], &[0x01, 0x00, 0x04, 0x05], "{}: 05040001h", d.name);
        d.answers_normally();
    }
}

/// SYNC at 8000 frames/s for 1 s in OPERATIONAL: TPDO2 (synchronous, type 1) answers every
/// SYNC, the heartbeat keeps its period, SDO requests in the flood are answered.
#[test]
fn a_sync_flood() {
    for mut d in duts() {
        let id = d.id as u16;
        d.bus.send(Frame::std(0, &[0x01, d.id]));
        d.bus.drain();
        let start = d.bus.now();
        for k in 0..8000u64 {
            d.bus.advance_to(start.add_micros((k + 1) * 125));
            d.bus.send(Frame::std(0x80, &[]));
            if k % 1000 == 500 {
                assert_eq!(sdo_read(&mut d.bus, d.id, 0x1017, 0), 100, "{}", d.name);
            }
        }
        d.bus.advance_to(start.add_millis(1000));
        let seen = d.log(start, d.bus.now());
        let tpdo2 = seen.iter().filter(|s| s.frame.id == CanId::Std(0x280 + id)).count();
        assert_eq!(tpdo2, 8000, "{}: one TPDO2 per SYNC", d.name);
        let beats: Vec<_> = seen.iter().filter(|s| s.frame.id == CanId::Std(0x700 + id)).map(|s| s.at).collect();
        assert_eq!(beats.len(), 10, "{}: {beats:?} from {start:?}", d.name);
        assert!(beats.windows(2).all(|w| w[1].micros_since(w[0]) == 100_000), "{}", d.name);
        d.bus.send(Frame::std(0, &[0x80, d.id]));
        d.answers_normally();
    }
}

/// 1000 NMT resets (node, communication, broadcast and addressed) 50 µs apart: every reset
/// ends in one boot-up, the node comes back PRE-OPERATIONAL with its stored parameters (the
/// heartbeat written by SDO and not saved is gone) and answers.
#[test]
fn an_nmt_reset_storm() {
    for mut d in duts() {
        let id = d.id as u16;
        let start = d.bus.now();
        for k in 0..1000u64 {
            d.bus.advance_to(start.add_micros(k * 50));
            let cs = if k % 2 == 0 { 0x81 } else { 0x82 };
            let target = if k % 3 == 0 { 0 } else { d.id };
            d.bus.send(Frame::std(0, &[cs, target]));
        }
        d.bus.advance(10);
        let seen: Vec<_> = d.bus.drain().into_iter().filter(|s| s.from == Sender::Node(0)).collect();
        let boots = seen.iter().filter(|s| s.frame.id == CanId::Std(0x700 + id) && s.frame.payload() == [0]).count();
        assert_eq!(boots, 1000, "{}: one boot-up per reset", d.name);
        assert_eq!(d.bus.station(0).nmt(), Some(NmtState::PreOperational));
        assert_eq!(sdo_read(&mut d.bus, d.id, 0x1017, 0), 0, "{}: the unsaved heartbeat is gone", d.name);
        for n in [Some(d.id), d.twin].into_iter().flatten() {
            sdo_write(&mut d.bus, n, 0x1017, 0, 2, 100);
        }
        d.bus.drain();
        d.answers_normally();
    }
}

/// LSS requests between the segments of an SDO upload: LSS answers, the transfer goes on and
/// delivers the whole value.
#[test]
fn lss_traffic_during_an_sdo_transfer() {
    for mut d in duts() {
        let id = d.id;
        let (_, a) = sdo_exchange(&mut d.bus, id, upload_request(0x1008, 0));
        assert_eq!(a[0], 0x41, "{}", d.name);
        let size = u32::from_le_bytes([a[4], a[5], a[6], a[7]]) as usize;
        let mut name = Vec::new();
        let mut toggle = 0u8;
        let lss = [
            [0x04, 0x01, 0, 0, 0, 0, 0, 0],
            [0x5E, 0, 0, 0, 0, 0, 0, 0],
            [0x5A, 0, 0, 0, 0, 0, 0, 0],
            [0x04, 0x00, 0, 0, 0, 0, 0, 0],
        ];
        let mut k = 0;
        while name.len() < size {
            if k < lss.len() {
                d.bus.send(Frame::std(0x7E5, &lss[k]));
                let answers: Vec<_> = d.bus.drain().into_iter().filter(|s| s.frame.id == CanId::Std(0x7E4)).collect();
                match lss[k][0] {
                    0x5E => {
                        let mine: Vec<_> = answers.iter().filter(|s| s.frame.data[1] == id).collect();
                        assert_eq!(mine.len(), 1, "{}: inquire node-ID", d.name);
                    }
                    0x5A => assert!(answers.iter().all(|s| s.frame.data[..5] == [0x5A, 0x95, 0x01, 0, 0])),
                    _ => assert!(answers.is_empty()),
                }
                k += 1;
            }
            let (_, s) = sdo_exchange(&mut d.bus, id, [0x60 | toggle, 0, 0, 0, 0, 0, 0, 0]);
            assert_eq!(s[0] & 0x10, toggle, "{}", d.name);
            let n = 7 - ((s[0] >> 1) & 7) as usize;
            name.extend_from_slice(&s[1..1 + n]);
            toggle ^= 0x10;
            if s[0] & 1 != 0 {
                break;
            }
        }
        assert_eq!(name.len(), size, "{}", d.name);
        let expected = d.name.split(' ').next().unwrap_or_default();
        assert_eq!(String::from_utf8_lossy(&name), expected, "{}", d.name);
        d.answers_normally();
    }
}

/// The SDO download that vanishes must not have written anything, and a write afterwards
/// works: the node keeps no half state.
#[test]
fn a_write_after_an_abandoned_download_works() {
    for mut d in duts() {
        sdo_exchange(&mut d.bus, d.id, [0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0]);
        d.bus.advance(1500);
        d.bus.drain();
        let (_, a) = sdo_exchange(&mut d.bus, d.id, download_request(0x1017, 0, 2, 250));
        assert_eq!(a, [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0], "{}", d.name);
        sdo_write(&mut d.bus, d.id, 0x1017, 0, 2, 100);
        d.answers_normally();
    }
}

/// Receive overruns (frames lost because the firmware's receive FIFO was full, e.g. behind a
/// long flash erase): none of the manuals' EMCY tables has a code for them, so the node raises
/// none; it changes no state and answers normally.
#[test]
fn receive_overruns_change_nothing() {
    for mut d in duts() {
        let before: Vec<u32> =
            (0..d.bus.station(0).core().od.table().len()).map(|p| d.bus.station(0).core().od.get(p)).collect();
        for _ in 0..1000 {
            d.sensor.bus_event(BusEvent::RxOverrun);
        }
        d.bus.advance(0);
        assert_eq!(d.frames(), [], "{}: no EMCY for an overrun", d.name);
        let after: Vec<u32> = (0..before.len()).map(|p| d.bus.station(0).core().od.get(p)).collect();
        assert_eq!(before, after, "{}: the dictionary is untouched", d.name);
        d.answers_normally();
    }
}
