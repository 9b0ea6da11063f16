//! Boot and the main loop.
//!
//! One loop does everything, in this order each turn: feed the watchdog, hand the node the
//! received frames and the controller's events, run its timers when due, carrying out its
//! outputs after each of these calls (frames into the transmit queue, parameter saves, bit-rate
//! switches; D-ARCH-3), re-program the filters
//! when the node's identifiers changed, fill the mailboxes, show the device's state; then wait
//! for whichever comes first: a frame, a free mailbox, the node's next deadline, the next change
//! of the LEDs, or the next sample. The sample period (1 ms) makes the loop turn at least that
//! often, which is what keeps the watchdog fed: a loop that stops turning resets the MCU.

use board_plan::straps::serial_from_uid;
use boards::mcu::{Mcu, Watchdog};
use boards::Io;
use embassy_futures::select::select;
use embassy_time::{Duration, Timer};
use od_core::encoder::program_serial;
use od_core::j1939::node::{J1939Device, J1939Node};
use od_core::node::{CanopenDevice, Device, Node, Output};
use od_core::od::Group;
use od_core::storage::{Loaded, Record};
use od_core::time::earliest;
use od_core::DeviceStation;

use crate::can::Bus;
use crate::params::{self, Params};
use crate::{now, wake_at};

/// Powers the node on from what the parameter pages hold. A board whose pages hold no serial
/// number (factory data, 1018h sub 4; not the AP10T, whose 1018h sub 4 is a constant) gets one
/// derived from the MCU's unique ID, in RAM only:
/// the production line writes the real one, and the first save keeps whichever the node has.
pub fn boot<D: CanopenDevice>(device: D, params: &mut Params, uid: &[u8; 12]) -> Node<D> {
    let loaded = params.load();
    let has_serial = loaded.image().is_some_and(|image| image.get(0x1018, 4).is_some());
    let mut node = Node::boot(device, &loaded);
    // Only where the serial number is factory data: the AP10T's is a constant FFFFFFFFh.
    let od = &node.core().od;
    let factory = od.pos(0x1018, 4).is_some_and(|p| od.entry(p).group == Group::Factory);
    if !has_serial && factory {
        let (_, core) = node.split();
        program_serial(&mut core.od, serial_from_uid(uid));
    }
    node
}

/// Powers a J1939 node on from what the parameter pages hold; a board without a stored serial
/// number gets one derived from the MCU's unique ID, as [`boot`] does (the NAME's identity
/// number follows it, D-J1939-16).
pub fn boot_j1939<D: J1939Device>(device: D, params: &mut Params, uid: &[u8; 12]) -> J1939Node<D> {
    let loaded = params.load();
    let has_serial = loaded.image().is_some_and(|image| image.get(0x1018, 4).is_some());
    if has_serial {
        return J1939Node::boot(device, &loaded);
    }
    // The serial is factory data the NAME is built from at boot: put it in the image first.
    let mut image = loaded.image().cloned().unwrap_or_default();
    let table = device.table();
    for e in table.iter().filter(|e| (e.index, e.sub) == (0x1018, 4) || (e.index, e.sub) == (0x650B, 0)) {
        let _ = image.set(Record::of(e, serial_from_uid(uid)));
    }
    J1939Node::boot(device, &Loaded::Image(image))
}

/// Carries out what the node asks for: frames into the transmit queue, parameter saves (answered
/// when the flash is written), bit-rate switches.
fn serve<N: DeviceStation>(node: &mut N, bus: &mut Bus, params: &mut Params, watchdog: &mut Watchdog) {
    while let Some(output) = node.next_output() {
        match output {
            Output::Frame(frame) => {
                crate::boot_time::frame_queued();
                bus.send(frame)
            }
            Output::Store(groups) => {
                watchdog.pet();
                let result = params.save(node.context(), groups);
                if result.is_err() {
                    defmt::error!("parameter save failed");
                }
                node.store_done(result.map_err(|_| ()), now());
            }
            Output::SetBitrate(rate) => {
                bus.set_bitrate(rate, node.listen_only());
            }
        }
    }
}

/// Runs the CANopen `device` on the board for ever: powers it on from the parameter pages in
/// `mcu`'s flash, joins the bus at the stored bit rate, and loops ([`drive`]). `identity` is
/// [`od_core::storage::identity`] of the device's dictionary, which each binary computes
/// when it is built (a `const`) rather than walking its dictionary at every boot.
pub async fn run<D: CanopenDevice, I: Io<D>>(device: D, identity: u32, mcu: Mcu, io: I) -> ! {
    drive(mcu, identity, |params, uid| boot(device, params, uid), io).await
}

/// The main loop over any node, CANopen or J1939, through the core's shell interface
/// ([`od_core::Station`], [`DeviceStation`]): `make` powers the node on from the parameter
/// pages of the device whose images carry `identity` ([`run`]; inside this future, so that
/// the node is stored once).
pub async fn drive<N, I>(mcu: Mcu, identity: u32, make: impl FnOnce(&mut Params, &[u8; 12]) -> N, mut io: I) -> !
where
    N: DeviceStation,
    N::Device: Device,
    I: Io<N::Device>,
{
    let Mcu { can, mut standby, flash, mut watchdog, reset, uid } = mcu;
    if reset.is_fault() {
        defmt::warn!("reset by the watchdog: the main loop had stopped");
    }
    let mut params = params::open(flash, identity);
    let mut node = make(&mut params, &uid);
    // The transceiver leaves standby only now; the controller, in sleep until `Bus::start`
    // enables it, keeps its TX pin recessive meanwhile.
    standby.set(false);
    let mut bus = Bus::start(can, node.context().bitrate);
    // Automatic bit-rate detection: silent from the start (D-AP-20).
    if node.listen_only() {
        bus.set_bitrate(node.context().bitrate, true);
    }
    watchdog.unleash();

    let period = Duration::from_micros(io.period_us(node.device()) as u64);
    let mut next_sample = embassy_time::Instant::now() + period;
    let mut filters = None;
    let mut dropped = 0;
    let mut lost_outputs = 0;
    loop {
        watchdog.pet();
        let t = now();
        // The node's outputs are carried out after every call, so its outbox never holds more
        // than one call's worth (`od_core::output::WORST_CALL_FRAMES`) and drops nothing.
        while let Some(frame) = bus.receive() {
            node.on_frame(&frame, t);
            serve(&mut node, &mut bus, &mut params, &mut watchdog);
        }
        bus.events(|event| node.on_bus_event(event, t));
        serve(&mut node, &mut bus, &mut params, &mut watchdog);
        if node.next_deadline().is_some_and(|d| d <= t) {
            node.poll(t);
            serve(&mut node, &mut bus, &mut params, &mut watchdog);
        }
        if node.context().out.dropped() != lost_outputs {
            lost_outputs = node.context().out.dropped();
            defmt::error!("node outbox full: {=u32} outputs lost", lost_outputs);
        }
        let generation = (node.rx_ids_generation(), node.listen_only());
        if filters != Some(generation) {
            if node.listen_only() {
                bus.accept_all();
            } else {
                bus.set_filters(&node.rx_ids(), &node.rx_masks());
            }
            filters = Some(generation);
        }
        bus.pump();
        if bus.dropped() != dropped {
            dropped = bus.dropped();
            defmt::warn!("transmit queue full: {=u32} frames dropped", dropped);
        }
        let (device, core) = node.split();
        let led_change = io.show(device, core, t);

        // One timer for whichever comes first: the node's or the LEDs' next deadline, or the
        // next sample.
        let mut wake = next_sample;
        if let Some(t) = earliest(node.next_deadline(), led_change) {
            wake = wake.min(embassy_time::Instant::from_micros(t.as_micros()));
        }
        let _ = select(bus.ready(), Timer::at(wake_at(wake))).await;
        if embassy_time::Instant::now() >= next_sample {
            let (device, core) = node.split();
            io.sample(device, core, now());
            // On the period grid; a period the loop missed (a flash erase) is skipped, not
            // made up in a burst of samples at one instant.
            next_sample += period;
            let late = embassy_time::Instant::now();
            if next_sample <= late {
                next_sample = late + period;
            }
        }
    }
}
