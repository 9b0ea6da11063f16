//! The live view's frame decoder: what a CANopen frame means, in one line, and the line
//! itself, fitted to the terminal.
//!
//! Numbers: SDO and LSS values are shown in hex with a `0x` prefix (an SDO carries raw bytes of
//! any type; the EDS and the manuals give most of them in hex), PDO values in decimal without a
//! prefix (the mapped objects' types are known, so they are numbers of their kind, with the
//! unit where one is known). Identifiers, `index:sub`, EMCY codes and the frame's bytes are hex
//! as in candump (D-SIM-16).

use od_core::node::Core;
use od_core::{CanId, Frame};

/// A node on the bus as the decoder sees it.
pub struct Known<'a> {
    /// Shown as `LABEL#ID`.
    pub label: &'a str,
    /// Its state.
    pub core: &'a Core,
}

fn name(nodes: &[Known], id: u8) -> String {
    match nodes.iter().find(|k| k.core.node_id == id) {
        Some(k) => format!("{}#{id}", k.label),
        None => format!("node {id}"),
    }
}

fn state(code: u8) -> &'static str {
    match code & 0x7F {
        0x00 => "boot-up",
        0x04 => "STOPPED",
        0x05 => "OPERATIONAL",
        0x7F => "PRE-OPERATIONAL",
        _ => "unknown state",
    }
}

fn le(data: &[u8]) -> u32 {
    data.iter().rev().fold(0, |v, b| (v << 8) | *b as u32)
}

/// `8 bytes` of an SDO frame as `idx:sub`.
fn mux(d: &[u8]) -> String {
    format!("{:04X}:{:02X}", u16::from_le_bytes([d[1], d[2]]), d[3])
}

fn sdo(d: &[u8], request: bool) -> String {
    if d.len() != 8 {
        return "malformed (not 8 bytes)".into();
    }
    let cmd = d[0];
    let exp_size = |c: u8| if c & 0x01 != 0 { 4 - ((c >> 2) & 3) as usize } else { 4 };
    match (request, cmd >> 5) {
        (_, 4) => format!("abort {} code {:08X}", mux(d), le(&d[4..8])),
        (true, 2) => format!("read {}", mux(d)),
        (true, 1) if cmd & 0x02 != 0 => format!("write {} = 0x{:X}", mux(d), le(&d[4..4 + exp_size(cmd)])),
        (true, 1) => format!("write {} ({} bytes, segmented)", mux(d), le(&d[4..8])),
        (true, 0) => format!("segment{}", if cmd & 1 != 0 { " (last)" } else { "" }),
        (true, 3) => "segment request".into(),
        (false, 2) if cmd & 0x02 != 0 => format!("{} = 0x{:X}", mux(d), le(&d[4..4 + exp_size(cmd)])),
        (false, 2) => format!("{} ({} bytes, segmented)", mux(d), le(&d[4..8])),
        (false, 3) => format!("{} written", mux(d)),
        (false, 0) => {
            let text: String =
                d[1..8].iter().map(|&b| if b.is_ascii_graphic() || b == b' ' { b as char } else { '.' }).collect();
            format!("segment \"{text}\"{}", if cmd & 1 != 0 { " (last)" } else { "" })
        }
        (false, 1) => "segment acknowledged".into(),
        (_, 5) | (_, 6) => "block transfer".into(),
        _ => format!("command {cmd:02X}"),
    }
}

fn lss(d: &[u8], request: bool) -> String {
    let Some(&cs) = d.first() else { return "empty".into() };
    let what = match cs {
        0x04 => {
            return format!("switch state global {}", if d.get(1) == Some(&1) { "CONFIGURATION" } else { "WAITING" })
        }
        0x11 if request => return format!("configure node-ID {}", d.get(1).copied().unwrap_or(0)),
        0x11 => "configure node-ID",
        0x13 => "configure bit timing",
        0x15 => "activate bit timing",
        0x17 => "store configuration",
        0x40..=0x43 => "switch state selective",
        0x44 => "switch state selective: selected",
        0x46..=0x4B => "identify remote slave",
        0x4C => "identify non-configured remote slave",
        0x4F => "identify slave",
        0x50 => "identify non-configured slave",
        0x51 => "fastscan",
        0x5A => "inquire vendor-ID",
        0x5B => "inquire product code",
        0x5C => "inquire revision",
        0x5D => "inquire serial number",
        0x5E => "inquire node-ID",
        _ => return format!("command {cs:02X}"),
    };
    if request || d.len() < 5 {
        what.into()
    } else if matches!(cs, 0x11 | 0x13 | 0x17) {
        format!("{what}: {}", if d[1] == 0 { "ok".into() } else { format!("error {}", d[1]) })
    } else if matches!(cs, 0x5A..=0x5E) {
        format!("{what}: 0x{:X}", le(&d[1..5]))
    } else {
        what.into()
    }
}

/// A PDO's mapped values, from the node's mapping entries `map` (1600h/1A00h + n).
fn pdo_values(core: &Core, map: u16, data: &[u8]) -> String {
    let od = &core.od;
    let count = od.value(map, 0).unwrap_or(0).min(8);
    let mut bit = 0usize;
    let mut out = Vec::new();
    for sub in 1..=count as u8 {
        let Some(m) = od.value(map, sub) else { break };
        let (index, s, bits) = ((m >> 16) as u16, (m >> 8) as u8, (m & 0xFF) as usize);
        if bits == 0 || bit + bits > data.len() * 8 || !bit.is_multiple_of(8) || !bits.is_multiple_of(8) {
            break;
        }
        let raw = le(&data[bit / 8..(bit + bits) / 8]);
        bit += bits;
        let value = if bits < 32 && raw >> (bits - 1) & 1 != 0 && signed(core, index, s) {
            (raw as i64) - (1i64 << bits)
        } else if bits == 32 && signed(core, index, s) {
            raw as i32 as i64
        } else {
            raw as i64
        };
        let label = od.find(index, s).ok().map(|p| od.table()[p].name()).unwrap_or("?");
        // A linear position (6020h, or 6004h) in millimetres, from the step size (6005h.01, nm).
        match od.value(0x6005, 1).filter(|nm| matches!(index, 0x6004 | 0x6020) && *nm > 0) {
            Some(nm) => out.push(format!("{label}={value} ({:.1} mm)", value as f64 * nm as f64 / 1e6)),
            None => out.push(format!("{label}={value}")),
        }
    }
    out.join(" ")
}

fn signed(core: &Core, index: u16, sub: u8) -> bool {
    use od_core::od::DataType;
    core.od.find(index, sub).ok().is_some_and(|p| {
        matches!(core.od.table()[p].dtype, DataType::Integer8 | DataType::Integer16 | DataType::Integer32)
    })
}

/// One line describing `frame`, with `nodes` (the nodes on its bus) to name senders and decode
/// their PDOs.
pub fn describe(frame: &Frame, nodes: &[Known]) -> String {
    let d = frame.payload();
    let id = match frame.id {
        CanId::Std(id) => id,
        CanId::Ext(_) => return super::j1939::describe(frame, nodes),
    };
    let node = (id & 0x7F) as u8;
    if frame.rtr {
        return match id {
            0x701..=0x77F => format!("node guarding request to {}", name(nodes, node)),
            _ => format!("remote request {id:03X}"),
        };
    }
    match id {
        0x000 => {
            let cmd = match d.first() {
                Some(0x01) => "OPERATIONAL",
                Some(0x02) => "STOPPED",
                Some(0x80) => "PRE-OPERATIONAL",
                Some(0x81) => "RESET NODE",
                Some(0x82) => "RESET COMMUNICATION",
                _ => return "NMT (malformed)".into(),
            };
            match d.get(1) {
                Some(0) => format!("NMT all nodes -> {cmd}"),
                Some(&n) => format!("NMT {} -> {cmd}", name(nodes, n)),
                None => "NMT (malformed)".into(),
            }
        }
        0x080 => match d.first() {
            Some(c) => format!("SYNC counter={c}"),
            None => "SYNC".into(),
        },
        0x081..=0x0FF => {
            if d.len() == 8 {
                format!(
                    "{} EMCY {:04X} register {:02X} {}",
                    name(nodes, node),
                    u16::from_le_bytes([d[0], d[1]]),
                    d[2],
                    if d[0] == 0 && d[1] == 0 { "(error reset)" } else { "" }
                )
                .trim_end()
                .to_string()
            } else {
                format!("{} EMCY (malformed)", name(nodes, node))
            }
        }
        0x580..=0x5FF => format!("SDO {id:03X} {}", sdo(d, false)),
        0x600..=0x67F => format!("SDO {id:03X} {}", sdo(d, true)),
        0x701..=0x77F => {
            format!("{} heartbeat {}", name(nodes, node), d.first().map(|&s| state(s)).unwrap_or("(empty)"))
        }
        0x7E5 => format!("LSS request {}", lss(d, true)),
        0x7E4 => format!("LSS response {}", lss(d, false)),
        _ => pdo(id, d, nodes).unwrap_or_else(|| format!("{id:03X}")),
    }
}

/// A PDO some node sends (TPDO) or receives (RPDO) on `id`.
fn pdo(id: u16, d: &[u8], nodes: &[Known]) -> Option<String> {
    for k in nodes {
        for (comm, map, kind) in [(0x1800u16, 0x1A00u16, "TPDO"), (0x1400, 0x1600, "RPDO")] {
            for n in 0..4u16 {
                let Some(cob) = k.core.od.value(comm + n, 1) else { continue };
                if cob & 0x8000_0000 == 0 && CanId::from_cob_id(cob) == CanId::Std(id) {
                    let values = pdo_values(k.core, map + n, d);
                    return Some(format!("{}#{} {kind}{} {values}", k.label, k.core.node_id, n + 1).trim_end().into());
                }
            }
        }
    }
    None
}

/// The J1939 parameter group of a 29-bit identifier (J1939-21 5.1.2): in PDU1 format (PF below
/// F0h) the PDU specific byte is the destination address, not part of the PGN.
pub(super) fn j1939_pgn(id: u32) -> String {
    let (dp_pf, ps) = ((id >> 8) & 0x3FF00, (id >> 8) & 0xFF);
    if (id >> 16) & 0xFF < 0xF0 {
        format!("J1939 PGN {dp_pf:05X} to {ps:02X}")
    } else {
        format!("J1939 PGN {:05X}", dp_pf | ps)
    }
}

/// The live view's line for `frame` on `bus` (candump's columns, then `text`), cut to `width`
/// characters with a final `…` if it is longer (`None`: never cut).
pub fn view_line(bus: &str, frame: &Frame, text: &str, width: Option<usize>) -> String {
    let id = match frame.id {
        CanId::Std(id) => format!("{id:03X}"),
        CanId::Ext(id) => format!("{id:08X}"),
    };
    let bytes: Vec<String> = frame.payload().iter().map(|x| format!("{x:02X}")).collect();
    let data = if frame.rtr { "remote request".to_string() } else { bytes.join(" ") };
    fit(&format!("{bus:<5} {id:>8}  [{}]  {data:<23}  {text}", frame.len), width)
}

/// `line` cut to `width` characters, the last one `…`, if it is longer.
pub fn fit(line: &str, width: Option<usize>) -> String {
    match width {
        Some(w) if w > 0 && line.chars().count() > w => {
            let mut cut: String = line.chars().take(w - 1).collect();
            cut.push('…');
            cut
        }
        _ => line.to_string(),
    }
}
