//! The device registry: how each `--device` kind becomes nodes on a segment, each with its
//! parameter flash and, for encoders, a simulated sensor. Every kind is one arm of `plan`.

use std::f64::consts::TAU;
use std::path::Path;

use board_plan::straps::serial_from_uid;
use od_core::devices::{sgh10, sgh50, wv5800m};
use od_core::encoder::rotary;
use od_core::encoder::{program_serial, Encoder};
use od_core::lss::Lss;
use od_core::nmt::NmtState;
use od_core::node::{BusEvent, CanopenDevice, Context, Node, Output, RxIds};
use od_core::od::{CoreHook, Entry, Hook};
use od_core::storage::{identity, Image, Loaded, ParamFlash, Record, Region};
use od_core::DeviceStation;
use od_core::{Frame, Instant};

use super::options::{DeviceSpec, Kind, Motion, UNCONFIGURED};
use crate::flash::{FileFlash, RamFlash};
use crate::segment::{Boot, NodeFlash, Station};

/// The parameter pages each device reserves: four 1 KiB pages, as `memory.x` gives the firmware.
pub const REGION: Region = Region { offset: 0, pages: 4 };

/// An encoder node, CANopen or J1939, with its simulated sensor: the sensor is sampled at the
/// device's period.
pub struct Sensed<N: DeviceStation> {
    node: N,
    /// What the device shows (LEDs, screen), for the live view.
    panel: Option<Panel<N>>,
    motion: Motion,
    /// The raw value's range (0..=max).
    max: u32,
    next_sample: Instant,
}

impl<N: DeviceStation> Sensed<N>
where
    N::Device: Encoder,
{
    /// `node` whose sensor moves as `motion` within 0..=`max`.
    pub fn new(node: N, motion: Motion, max: u32) -> Sensed<N> {
        Sensed { node, panel: None, motion, max, next_sample: Instant::ZERO }
    }

    /// Shows what `panel` makes of the node in the live view.
    pub fn with_panel(mut self, panel: Panel<N>) -> Sensed<N> {
        self.panel = Some(panel);
        self
    }

    /// What the node shows, by its panel.
    pub(crate) fn panel_text(&self) -> Option<String> {
        self.panel.map(|p| p(&self.node))
    }

    /// Holds the sensor at `raw` (the control port's `position`).
    pub(crate) fn hold(&mut self, raw: u32) -> Result<(), String> {
        if raw > self.max {
            return Err(format!("{raw} is beyond the sensor's range 0..={}", self.max));
        }
        self.motion = Motion::Fixed(raw);
        // Sampled at the next turn, not at the next point of the device's grid.
        self.next_sample = Instant::ZERO;
        Ok(())
    }
}

/// What a node shows its user, as text.
pub type Panel<N> = fn(&N) -> String;

/// The WV5800M's three LEDs (CiA 303-3 green and red, yellow over-speed).
fn wv5800m_leds(node: &Node<wv5800m::Wv5800m>) -> String {
    let l = node.device().leds();
    format!("LEDs green={:?} red={:?} yellow={:?}", l.green, l.red, l.yellow)
}

/// The raw sensor value of `motion` within 0..=`max` at `t` seconds.
pub fn raw_at(motion: Motion, max: u32, t: f64) -> u32 {
    let v = match motion {
        Motion::Fixed(v) => return v,
        Motion::Ramp(rate) => (rate * t).rem_euclid(max as f64 + 1.0),
        Motion::Sine(ampl, period) => max as f64 / 2.0 + ampl * (TAU * t / period).sin(),
    };
    v.clamp(0.0, max as f64) as u32
}

impl<N: DeviceStation> od_core::Station for Sensed<N>
where
    N::Device: Encoder,
{
    fn on_frame(&mut self, frame: &Frame, now: Instant) {
        self.node.on_frame(frame, now)
    }
    fn poll(&mut self, now: Instant) {
        if now >= self.next_sample {
            let raw = raw_at(self.motion, self.max, now.as_micros() as f64 / 1e6);
            let (dev, ctx) = self.node.split();
            dev.on_sample(ctx, Ok(raw), now);
            let period = u64::from(self.node.device().sample_period_us().max(1));
            // The next sample on the device's grid; samples a late loop missed are skipped.
            self.next_sample = Instant::from_micros((now.as_micros() / period + 1) * period);
        }
        if self.node.next_deadline().is_some_and(|t| t <= now) {
            self.node.poll(now)
        }
    }
    fn next_deadline(&self) -> Option<Instant> {
        od_core::time::earliest(self.node.next_deadline(), Some(self.next_sample))
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

impl<E: Encoder + CanopenDevice> Station for Sensed<Node<E>> {
    fn nmt(&self) -> Option<NmtState> {
        Some(self.node.nmt_state())
    }
    fn lss(&self) -> Option<&Lss> {
        Some(self.node.lss())
    }
    fn panel(&self) -> Option<String> {
        self.panel_text()
    }
    fn set_sensor(&mut self, raw: u32) -> Result<(), String> {
        self.hold(raw)
    }
}

/// One node to put on a bus.
pub struct NodePlan {
    /// Shown in the live view (`SGH10`, `SGH50-A` ...).
    pub label: String,
    /// The bus.
    pub bus: String,
    /// Its parameter pages.
    pub params: Box<dyn NodeFlash>,
    /// How it powers on from them.
    pub boot: Boot,
}

/// Where flash files go (`None`: RAM, lost at exit).
pub struct Registry<'a> {
    state_dir: Option<&'a Path>,
}

impl<'a> Registry<'a> {
    /// Flash files in `state_dir`, if any.
    pub fn new(state_dir: Option<&'a Path>) -> Registry<'a> {
        Registry { state_dir }
    }

    /// The nodes of `spec`; `ordinal` numbers devices of the same kind on the same bus (it
    /// names the flash files, so the same command line finds the same flash again), `position`
    /// is the device's place on the command line (from 0; it makes the board's unique ID, see
    /// [`board_uid`]).
    pub fn build(&self, spec: &DeviceSpec, ordinal: usize, position: usize) -> Result<Vec<NodePlan>, String> {
        let mut plans = Vec::new();
        for (n, channel) in plan(spec, position)?.into_iter().enumerate() {
            let file = format!("{}-{}-{}{}.flash", spec.bus, spec.kind.name(), ordinal, channel.suffix);
            let node = match spec.node {
                Some(UNCONFIGURED) => Some(UNCONFIGURED),
                Some(id) if usize::from(id) + n > 127 => {
                    return Err(format!("--device {}: node {id}+{n} is beyond 127", spec.kind.name()))
                }
                Some(id) => Some(id + n as u8),
                None => None,
            };
            // `serial=` is the first channel's; the second channel is a board of its own.
            let serial = spec.serial.map(|s| s.wrapping_add(n as u32));
            // J1939: `address=` is what 5F0Ah.01 was set to, both channels alike (D-J1939-17);
            // their serial numbers, and so their NAMEs, differ.
            let node = if spec.kind.is_j1939() { spec.address } else { node };
            let params = self.params(&file, channel.table, node, serial)?;
            plans.push(NodePlan { label: channel.label, bus: spec.bus.clone(), params, boot: channel.boot });
        }
        Ok(plans)
    }

    fn params(
        &self,
        file: &str,
        table: &'static [Entry],
        node: Option<u8>,
        serial: Option<u32>,
    ) -> Result<Box<dyn NodeFlash>, String> {
        let id = identity(table);
        let mut params: Box<dyn NodeFlash> = match self.state_dir {
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
                let path = dir.join(file);
                let flash =
                    FileFlash::open(&path, REGION.pages as usize).map_err(|e| format!("{}: {e}", path.display()))?;
                let mut p = ParamFlash::new(flash, REGION, id);
                factory(&mut p, table, node, serial)?;
                Box::new(p)
            }
            None => {
                let mut p = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, id);
                factory(&mut p, table, node, serial)?;
                Box::new(p)
            }
        };
        params.power_on();
        Ok(params)
    }
}

/// The parameter pages ([`REGION`]) of a board the production line programmed with `node` (as
/// LSS stores it) and `serial` (factory data), everything else at its default: what the
/// simulator starts a new state file with, and what the Renode bench loads into the firmware's
/// parameter pages (`renode/images`).
pub fn factory_pages(table: &'static [Entry], node: Option<u8>, serial: Option<u32>) -> Result<Vec<u8>, String> {
    let mut p = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(table));
    factory(&mut p, table, node, serial)?;
    Ok(p.into_inner().bytes().to_vec())
}

/// A blank flash gets what the command line says was configured before: the node-ID (as LSS
/// stores it) and the serial number (factory data). A flash holding an image keeps it.
fn factory<F: embedded_storage::nor_flash::NorFlash>(
    p: &mut ParamFlash<F>,
    table: &'static [Entry],
    node: Option<u8>,
    serial: Option<u32>,
) -> Result<(), String> {
    if !matches!(p.load(), Loaded::Blank) {
        return Ok(());
    }
    let mut image = Image::new();
    if let Some(id) = node {
        let e = table
            .iter()
            .find(|e| matches!(e.hook, Hook::Core(CoreHook::PendingNodeId)))
            .ok_or("this device has no configurable node-ID")?;
        image.set(Record::of(e, id.into())).map_err(|_| "parameter image full")?;
    }
    if let Some(s) = serial {
        let e = table.iter().find(|e| e.index == 0x1018 && e.sub == 4).ok_or("this device has no serial number")?;
        image.set(Record::of(e, s)).map_err(|_| "parameter image full")?;
    }
    if !image.records().is_empty() {
        p.write(&image).map_err(|e| format!("writing the flash: {e:?}"))?;
    }
    Ok(())
}

/// One node of a device.
struct Channel {
    label: String,
    suffix: &'static str,
    table: &'static [Entry],
    boot: Boot,
}

/// Raw sensor range of a linear encoder: micrometres over its measuring range (0.1 mm steps).
const fn linear_max(max_steps: i64) -> u32 {
    (max_steps * 100) as u32
}

/// The 96-bit unique device ID of a simulated board (what an STM32 holds at 1FFFF7E8h): the
/// bus name's hash, then the device's `position` on the command line, its kind and its
/// `channel`. On one bus only the last four bytes differ between boards, and a CRC-32 tells
/// apart any two messages of equal length that differ within 32 consecutive bits, so
/// [`serial_from_uid`] gives every board of a bus its own serial number (D-SIM-14).
pub fn board_uid(bus: &str, kind: Kind, position: usize, channel: usize) -> [u8; 12] {
    let hash = bus.bytes().fold(0x811C_9DC5u32, |h, b| (h ^ b as u32).wrapping_mul(0x0100_0193));
    let kind = Kind::ALL.iter().position(|(_, k)| *k == kind).unwrap_or(0) as u8;
    let mut uid = [0u8; 12];
    uid[..4].copy_from_slice(b"SIM\0");
    uid[4..8].copy_from_slice(&hash.to_le_bytes());
    uid[8..10].copy_from_slice(&(position as u16).to_le_bytes());
    uid[10] = kind;
    uid[11] = channel as u8;
    uid
}

fn encoder_boot<E: Encoder + CanopenDevice + Clone + 'static>(
    device: E,
    motion: Motion,
    max: u32,
    panel: Option<Panel<Node<E>>>,
    uid: [u8; 12],
) -> Boot {
    Box::new(move |loaded: &Loaded| {
        let mut node = Node::boot(device.clone(), loaded);
        // As the firmware boots: no serial number in the flash, the one of the unique ID (in
        // RAM only; the production line writes the real one as factory data).
        if loaded.image().is_none_or(|image| image.get(0x1018, 4).is_none()) {
            program_serial(&mut node.split().1.od, serial_from_uid(&uid));
        }
        let sensed = Sensed::new(node, motion, max);
        Box::new(match panel {
            Some(p) => sensed.with_panel(p),
            None => sensed,
        })
    })
}

/// The nodes a device spec makes. The one place that knows every kind.
fn plan(spec: &DeviceSpec, position: usize) -> Result<Vec<Channel>, String> {
    let uid = |channel| board_uid(&spec.bus, spec.kind, position, channel);
    if spec.kind.is_j1939() {
        if spec.node.is_some() {
            return Err(format!("--device {}: a J1939 device takes address=, not node=", spec.kind.name()));
        }
    } else if spec.address.is_some() {
        return Err(format!("--device {}: a CANopen device takes node=, not address=", spec.kind.name()));
    }
    match spec.kind {
        Kind::Sgh10 => {
            if spec.redundant {
                return Err("--device sgh10: there is no redundant SGH10".into());
            }
            let variant = match spec.variant.as_deref() {
                None | Some("sgh10") | Some("SGH10") => sgh10::Variant::Sgh10,
                Some("sgh10l") | Some("SGH10L") => sgh10::Variant::Sgh10L,
                Some(v) => return Err(format!("--device sgh10: unknown variant {v} (sgh10, sgh10l)")),
            };
            let max = linear_max(sgh10::SPEC.max_steps);
            let motion = spec.motion.unwrap_or(Motion::Sine(max as f64 / 4.0, 20.0));
            Ok(vec![Channel {
                label: "SGH10".into(),
                suffix: "",
                table: sgh10::TABLE,
                boot: encoder_boot(sgh10::Sgh10::new(variant), motion, max, None, uid(0)),
            }])
        }
        Kind::Sgh50 => {
            if spec.variant.is_some() {
                return Err("--device sgh50: use redundant=true for the redundant version".into());
            }
            let max = linear_max(sgh50::SPEC.max_steps);
            let motion = spec.motion.unwrap_or(Motion::Ramp(20_000.0));
            if !spec.redundant {
                return Ok(vec![Channel {
                    label: "SGH50".into(),
                    suffix: "",
                    table: sgh50::TABLE,
                    boot: encoder_boot(sgh50::Sgh50::new(sgh50::Variant::Single), motion, max, None, uid(0)),
                }]);
            }
            let ch = |c, n, label: &str, suffix, table| Channel {
                label: label.into(),
                suffix,
                table,
                boot: encoder_boot(sgh50::Sgh50::new(sgh50::Variant::Redundant(c)), motion, max, None, uid(n)),
            };
            Ok(vec![
                ch(sgh50::Channel::First, 0, "SGH50-A", "a", sgh50::TABLE),
                ch(sgh50::Channel::Second, 1, "SGH50-B", "b", sgh50::TABLE),
            ])
        }
        Kind::Wv5800m => {
            if spec.redundant {
                return Err("--device wv5800m: there is no redundant WV5800M".into());
            }
            let variant = wv5800m_variant(spec.variant.as_deref())?;
            let max = rotary::raw_range(variant.turns.revolutions()) - 1;
            // Half a revolution per second (30 rpm) unless told otherwise.
            let motion = spec.motion.unwrap_or(Motion::Ramp(rotary::PHYSICAL_STEPS as f64 / 2.0));
            Ok(vec![Channel {
                label: variant.model.name().into(),
                suffix: "",
                table: wv5800m::table_of(variant),
                boot: encoder_boot(wv5800m::Wv5800m::new(variant), motion, max, Some(wv5800m_leds), uid(0)),
            }])
        }
        Kind::Ap10t => ap10t(spec),
        Kind::Wv58mr => {
            use od_core::devices::wv58mr;
            let turns = wv58mr_turns(spec.variant.as_deref())?;
            let max = rotary::raw_range(turns.revolutions()) - 1;
            let motion = spec.motion.unwrap_or(Motion::Ramp(rotary::PHYSICAL_STEPS as f64 / 2.0));
            let boot = move || -> Boot {
                Box::new(move |loaded: &Loaded| {
                    let node = od_core::j1939::node::J1939Node::boot(wv58mr::Wv58mr::new(turns), loaded);
                    Box::new(Sensed::new(node, motion, max).with_panel(super::j1939::leds))
                })
            };
            let one = |label: &str, suffix| Channel {
                label: label.into(),
                suffix,
                table: wv58mr::table_of(turns),
                boot: boot(),
            };
            // D-J1939-17: the two channels of a redundant WV58MR are two nodes on the bus.
            Ok(if spec.redundant { vec![one("WV58MR-A", "a"), one("WV58MR-B", "b")] } else { vec![one("WV58MR", "")] })
        }
    }
}

/// `variant=` of a WV58MR: its revolutions, `mt12` (default), `mt8`, `mt4`, `st`.
fn wv58mr_turns(name: Option<&str>) -> Result<wv5800m::Turns, String> {
    use wv5800m::Turns;
    Ok(match name.unwrap_or("mt12").to_ascii_lowercase().as_str() {
        "st" | "1" => Turns::Single,
        "mt4" | "16" => Turns::Multi4,
        "mt8" | "256" => Turns::Multi8,
        "mt12" | "4096" => Turns::Multi12,
        v => return Err(format!("--device wv58mr: unknown variant {v} (st, mt4, mt8, mt12)")),
    })
}

/// The AP10T: one display whose bit rate is detected on the bus unless a stored one says
/// otherwise (factory 5F0Ah.03 = Auto baud); `node=` is its node-ID (factory 7Dh).
fn ap10t(spec: &DeviceSpec) -> Result<Vec<Channel>, String> {
    if spec.redundant || spec.variant.is_some() || spec.motion.is_some() {
        return Err("--device ap10t: no redundant=, variant= or motion= (a display has no sensor)".into());
    }
    if spec.serial.is_some() {
        return Err("--device ap10t: its serial number is a constant (FFFFFFFFh)".into());
    }
    Ok(vec![Channel {
        label: "AP10T".into(),
        suffix: "",
        table: od_core::devices::ap10t::table::TABLE,
        boot: Box::new(|loaded: &Loaded| Box::new(crate::ap10t::Display::boot(loaded))),
    }])
}

/// `variant=` of a WV5800M: model and revolutions, `wv4096` (default), `wv256`, `wv16`, `wv1`,
/// `wh4096` ... `wh1`.
fn wv5800m_variant(name: Option<&str>) -> Result<wv5800m::Variant, String> {
    use wv5800m::{Model, Turns, Variant};
    let name = name.unwrap_or("wv4096").to_ascii_lowercase();
    let (model, turns) = name.split_at(name.len().min(2));
    let model = match model {
        "wv" => Model::Wv,
        "wh" => Model::Wh,
        _ => {
            return Err(format!("--device wv5800m: unknown variant {name} (wv1, wv16, wv256, wv4096, wh1 ... wh4096)"))
        }
    };
    let turns = match turns {
        "1" => Turns::Single,
        "16" => Turns::Multi4,
        "256" => Turns::Multi8,
        "4096" | "" => Turns::Multi12,
        _ => {
            return Err(format!("--device wv5800m: unknown variant {name} (wv1, wv16, wv256, wv4096, wh1 ... wh4096)"))
        }
    };
    Ok(Variant { model, turns })
}

/// The ready-made bench: every device available so far on distinct node-IDs on can0.
pub fn bench() -> Vec<DeviceSpec> {
    let d = |kind, node, redundant, motion| DeviceSpec {
        kind,
        bus: "can0".into(),
        node: Some(node),
        address: None,
        serial: Some(1000 + node as u32),
        variant: None,
        redundant,
        motion: Some(motion),
    };
    vec![
        d(Kind::Sgh10, 10, false, Motion::Sine(300_000.0, 20.0)),
        d(Kind::Sgh50, 20, true, Motion::Ramp(50_000.0)),
        d(Kind::Wv5800m, 30, false, Motion::Sine(40_000.0, 8.0)),
        // An AP10T on node 40 as shipped (auto baud), showing the SGH10's position (D-SIM-19).
        DeviceSpec {
            kind: Kind::Ap10t,
            bus: "can0".into(),
            node: Some(40),
            address: None,
            serial: None,
            variant: None,
            redundant: false,
            motion: None,
        },
        // A redundant WV58MR on can1 (J1939, 250 kbit/s): both channels claim EFh, one moves.
        DeviceSpec {
            kind: Kind::Wv58mr,
            bus: "can1".into(),
            node: None,
            address: None,
            serial: Some(1050),
            variant: None,
            redundant: true,
            motion: Some(Motion::Sine(1_000_000.0, 10.0)),
        },
    ]
}
