//! The simulator's command line.

use std::path::PathBuf;

use od_core::Bitrate;

/// `node=unconfigured` (or 255): the node has no node-ID and waits for LSS.
pub const UNCONFIGURED: u8 = 0xFF;

/// `--help`.
pub const HELP: &str = "\
sim: the SIKO devices on simulated CAN buses, served over socketcand (TCP, rawmode)

Usage: sim [OPTIONS]

With no --device, starts the ready-made bench: every device available so far on distinct
node-IDs on can0 (500 kbit/s), encoders' sensors moving.

Options:
  --listen HOST:PORT      where socketcand clients connect (default 127.0.0.1:29536)
  --device KIND[:k=v,..]  add a device (repeatable). KIND: sgh10, sgh50, wv5800m, ap10t, wv58mr
                          keys: bus=can0|can1|..  node=N (CANopen node-ID 1..127, as if
                          configured and stored before, one per bus; node=unconfigured:
                          LSS only)  address=N (J1939)  variant=NAME
                          serial=N (factory serial number; default: one of the board's
                          own, distinct on its bus)
                          redundant=true (SGH50, WV58MR: both channels)
                          position=RAW (fixed sensor value) | motion=ramp:STEPS_PER_S |
                          motion=sine:AMPL:PERIOD_S
  --state-dir DIR         each device's flash is a file in DIR; restarting with the same
                          DIR is a power cycle (default: flash in RAM, lost at exit)
  --bitrate BUS=RATE      bus bit rate in kbit/s (can0 defaults to 500, can1 to 250) of a
                          bus with devices; a node set to another rate neither sees nor
                          sends frames (a bus where no node runs at its rate gets a hint)
  --socketcan BUS=IFACE   also bridge BUS to a SocketCAN interface (vcan0, can0 ...), where
                          the kernel has CAN support
  --quiet                 no live view
  --trace FILE            also write every frame to FILE as a candump log
  -h, --help              this text
";

/// A device kind of the product line.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    /// SGH10 draw-wire encoder (CANopen).
    Sgh10,
    /// SGH50 draw-wire encoder (CANopen), optionally redundant.
    Sgh50,
    /// AP10T position display (CANopen).
    Ap10t,
    /// WV5800M rotary encoder (CANopen).
    Wv5800m,
    /// WV58MR rotary encoder (J1939).
    Wv58mr,
}

impl Kind {
    /// Every kind with its command-line name.
    pub const ALL: [(&'static str, Kind); 5] = [
        ("sgh10", Kind::Sgh10),
        ("sgh50", Kind::Sgh50),
        ("ap10t", Kind::Ap10t),
        ("wv5800m", Kind::Wv5800m),
        ("wv58mr", Kind::Wv58mr),
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Kind::ALL.iter().find(|(_, k)| *k == self).map(|(n, _)| *n).unwrap_or("?")
    }

    /// Is the device a J1939 one (default bus can1)?
    pub fn is_j1939(self) -> bool {
        self == Kind::Wv58mr
    }
}

/// What a device's simulated sensor does.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum Motion {
    /// A fixed raw value.
    Fixed(u32),
    /// Raw value growing by this many steps per second (wrapping over the range).
    Ramp(f64),
    /// Raw value swinging around mid-range: amplitude (steps) and period (s).
    Sine(f64, f64),
}

/// One `--device`.
#[derive(Clone, PartialEq, Debug)]
pub struct DeviceSpec {
    /// The kind.
    pub kind: Kind,
    /// The bus it is on.
    pub bus: String,
    /// CANopen node-ID configured before (None: what its flash holds, or ex works;
    /// [`UNCONFIGURED`]: none, the node answers LSS only).
    pub node: Option<u8>,
    /// J1939 address.
    pub address: Option<u8>,
    /// Serial number (1018h.04).
    pub serial: Option<u32>,
    /// Product variant name.
    pub variant: Option<String>,
    /// Both channels of a redundant device.
    pub redundant: bool,
    /// The sensor (None: the device's own default).
    pub motion: Option<Motion>,
}

/// The parsed command line.
#[derive(Clone, PartialEq, Debug)]
pub struct Options {
    /// `--listen`.
    pub listen: String,
    /// `--device`s (empty: the ready-made bench).
    pub devices: Vec<DeviceSpec>,
    /// `--state-dir`.
    pub state_dir: Option<PathBuf>,
    /// `--bitrate`s.
    pub bitrates: Vec<(String, Bitrate)>,
    /// `--socketcan BUS=IFACE`s.
    pub socketcan: Vec<(String, String)>,
    /// `--quiet`.
    pub quiet: bool,
    /// `--trace`.
    pub trace: Option<PathBuf>,
    /// `--help`.
    pub help: bool,
}

/// The default `--listen`.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:29536";

impl Options {
    /// Parses the arguments (without the program name).
    pub fn parse<S: AsRef<str>>(args: &[S]) -> Result<Options, String> {
        let mut o = Options {
            listen: DEFAULT_LISTEN.into(),
            devices: Vec::new(),
            state_dir: None,
            bitrates: Vec::new(),
            socketcan: Vec::new(),
            quiet: false,
            trace: None,
            help: false,
        };
        let mut it = args.iter().map(|a| a.as_ref());
        while let Some(arg) = it.next() {
            let (name, inline) = match arg.split_once('=') {
                Some((n, v)) if n.starts_with("--") => (n, Some(v.to_string())),
                _ => (arg, None),
            };
            let mut value = |name: &str| {
                inline.clone().or_else(|| it.next().map(str::to_string)).ok_or(format!("{name} needs a value"))
            };
            match name {
                "-h" | "--help" => o.help = true,
                "--quiet" => o.quiet = true,
                "--listen" => {
                    let v = value(name)?;
                    if v.rsplit_once(':').is_none_or(|(_, p)| p.parse::<u16>().is_err()) {
                        return Err(format!("--listen {v}: expected HOST:PORT"));
                    }
                    o.listen = v;
                }
                "--device" => o.devices.push(parse_device(&value(name)?)?),
                "--state-dir" => o.state_dir = Some(value(name)?.into()),
                "--trace" => o.trace = Some(value(name)?.into()),
                "--bitrate" => {
                    let v = value(name)?;
                    let (bus, rate) = v.split_once('=').ok_or(format!("--bitrate {v}: expected BUS=RATE"))?;
                    check_bus(bus)?;
                    o.bitrates.push((bus.to_string(), parse_rate(rate)?));
                }
                "--socketcan" => {
                    let v = value(name)?;
                    let (bus, iface) = v.split_once('=').ok_or(format!("--socketcan {v}: expected BUS=IFACE"))?;
                    check_bus(bus)?;
                    if iface.is_empty() || iface.len() > 15 {
                        return Err(format!("--socketcan {v}: bad interface name"));
                    }
                    o.socketcan.push((bus.to_string(), iface.to_string()));
                }
                _ => return Err(format!("unknown option {arg} (see --help)")),
            }
        }
        Ok(o)
    }

    /// The bit rate of `bus`.
    pub fn bitrate(&self, bus: &str) -> Bitrate {
        match self.bitrates.iter().rev().find(|(b, _)| b == bus) {
            Some((_, r)) => *r,
            None if bus == "can1" => Bitrate::K250,
            None => Bitrate::K500,
        }
    }
}

/// A bit rate in kbit/s (`500`, `500k`, or `500000`).
pub fn parse_rate(text: &str) -> Result<Bitrate, String> {
    let t = text.trim_end_matches(['k', 'K']);
    let n = digits(t, 10).and_then(|n| u32::try_from(n).ok()).ok_or(format!("bad bit rate {text}"))?;
    let kbit = if n >= 10_000 { n / 1000 } else { n };
    Bitrate::ALL
        .into_iter()
        .find(|b| b.kbit() == kbit && (n < 10_000 || n.is_multiple_of(1000)))
        .ok_or(format!("bad bit rate {text} (10, 20, 50, 100, 125, 250, 500, 800, 1000 kbit/s)"))
}

fn check_bus(bus: &str) -> Result<(), String> {
    let ok = !bus.is_empty() && bus.len() <= 15 && bus.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(format!("bad bus name {bus}"))
    }
}

/// Digits only: Rust's parsers also take a leading `+`, which no number here has.
fn digits(text: &str, radix: u32) -> Option<u64> {
    let ok = !text.is_empty() && text.chars().all(|c| c.is_digit(radix));
    ok.then(|| u64::from_str_radix(text, radix).ok()).flatten()
}

fn number<T: TryFrom<u64>>(key: &str, v: &str) -> Result<T, String> {
    let n = match v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        Some(h) => digits(h, 16),
        None => digits(v, 10),
    }
    .ok_or_else(|| format!("{key}={v}: not a number"))?;
    T::try_from(n).map_err(|_| format!("{key}={v}: out of range"))
}

fn float(key: &str, v: &str) -> Result<f64, String> {
    v.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or(format!("{key}: bad number {v}"))
}

/// Parses `KIND[:key=value,...]`.
pub fn parse_device(text: &str) -> Result<DeviceSpec, String> {
    let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
    let kind = Kind::ALL
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(kind))
        .map(|(_, k)| *k)
        .ok_or(format!("unknown device kind {kind} (sgh10, sgh50, ap10t, wv5800m, wv58mr)"))?;
    let mut d = DeviceSpec {
        kind,
        bus: if kind.is_j1939() { "can1" } else { "can0" }.into(),
        node: None,
        address: None,
        serial: None,
        variant: None,
        redundant: false,
        motion: None,
    };
    for kv in rest.split(',').filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').ok_or(format!("{kv}: expected key=value"))?;
        match k {
            "bus" => {
                check_bus(v)?;
                d.bus = v.into();
            }
            "node" => {
                let n: u8 = if v == "unconfigured" { UNCONFIGURED } else { number(k, v)? };
                if !(1..=127).contains(&n) && n != UNCONFIGURED {
                    return Err(format!("node={v}: a CANopen node-ID is 1..127 (or unconfigured)"));
                }
                d.node = Some(n);
            }
            "address" => {
                let a: u8 = number(k, v)?;
                if a > 253 {
                    return Err(format!("address={v}: a J1939 address is 0..253"));
                }
                d.address = Some(a);
            }
            "serial" => d.serial = Some(number(k, v)?),
            "variant" => d.variant = Some(v.into()),
            "redundant" => {
                d.redundant = match v {
                    "true" | "1" | "yes" => true,
                    "false" | "0" | "no" => false,
                    _ => return Err(format!("redundant={v}: true or false")),
                }
            }
            "position" => d.motion = Some(Motion::Fixed(number(k, v)?)),
            "motion" => {
                let parts: Vec<&str> = v.split(':').collect();
                d.motion = Some(match parts.as_slice() {
                    ["ramp", s] => Motion::Ramp(float(k, s)?),
                    ["sine", a, p] => {
                        let p = float(k, p)?;
                        if p <= 0.0 {
                            return Err(format!("motion={v}: the period must be positive"));
                        }
                        Motion::Sine(float(k, a)?, p)
                    }
                    _ => return Err(format!("motion={v}: ramp:STEPS_PER_S or sine:AMPL:PERIOD_S")),
                });
            }
            _ => return Err(format!("unknown device key {k}")),
        }
    }
    Ok(d)
}
