//! J1939 devices in the simulator: the WV58MR channel as a station, and the live view's line
//! for a J1939 frame.

use od_core::encoder::Encoder;
use od_core::j1939::node::{J1939Device, J1939Node};
use od_core::wire::j1939::{AckControl, CamRequest, CamResponse, Message, Payload};
use od_core::Frame;

use super::decode::Known;
use super::devices::Sensed;
use crate::segment::Station;

/// A J1939 encoder channel's LEDs and claimed address, for the live view.
pub fn leds<E: Encoder + J1939Device>(node: &J1939Node<E>) -> String {
    let l = node.leds();
    let at = match node.source_address() {
        Some(a) => format!("SA {:02X}h", a.0),
        None => "claiming".into(),
    };
    format!("LEDs green={:?} red={:?} yellow={:?} ({at})", l.green, l.red, l.yellow)
}

impl<E: Encoder + J1939Device> Station for Sensed<J1939Node<E>> {
    fn panel(&self) -> Option<String> {
        self.panel_text()
    }
    fn set_sensor(&mut self, raw: u32) -> Result<(), String> {
        self.hold(raw)
    }
}

/// The sender of a J1939 frame from source address `sa`, by the nodes' active addresses.
fn sender(nodes: &[Known], sa: u8) -> String {
    match nodes.iter().find(|k| k.core.node_id == sa) {
        Some(k) => format!("{}@{sa:02X}h", k.label),
        None => format!("SA {sa:02X}h"),
    }
}

/// One line for a 29-bit frame: group, source (destination) and meaning.
pub fn describe(frame: &Frame, nodes: &[Known]) -> String {
    let Ok(m) = Message::parse(frame) else {
        return match frame.id {
            od_core::CanId::Ext(id) => format!("29-bit {id:08X} ({}, malformed)", super::decode::j1939_pgn(id)),
            od_core::CanId::Std(id) => format!("{id:03X}"),
        };
    };
    // A claim names its sender by NAME (two channels may claim one address at once).
    let from = match m.payload {
        Payload::AddressClaimed(c) | Payload::CannotClaim(c) => {
            match nodes
                .iter()
                .find(|k| k.core.od.pos(0x3001, 1).is_some() && od_core::j1939::node::name_of(&k.core.od) == c.name)
            {
                Some(k) => format!("{}@{:02X}h", k.label, m.id.source().0),
                None => sender(nodes, m.id.source().0),
            }
        }
        _ => sender(nodes, m.id.source().0),
    };
    let to = match m.id.destination() {
        Some(d) if d.0 == 0xFF => " -> all".to_string(),
        Some(d) => format!(" -> {}", sender(nodes, d.0)),
        None => String::new(),
    };
    let pgn = m.id.pgn().raw();
    let what = match m.payload {
        Payload::Request(r) => format!("Request PGN {} ({:05X}h)", r.pgn.raw(), r.pgn.raw()),
        Payload::Acknowledgement(a) => {
            let c = match a.control {
                AckControl::Ack => "ACK",
                AckControl::Nack => "NACK",
                AckControl::AccessDenied => "access denied",
                AckControl::CannotRespond => "cannot respond",
            };
            format!("{c} PGN {} for {:02X}h", a.pgn.raw(), a.address.0)
        }
        Payload::AddressClaimed(c) => format!("Address Claimed NAME {:016X}", c.name.raw()),
        Payload::CannotClaim(c) => format!("Cannot Claim NAME {:016X}", c.name.raw()),
        Payload::Cam21(r) => match r {
            CamRequest::Read { index, sub } => format!("CAM21 read {index:04X}:{sub:02X}"),
            CamRequest::Write { index, sub, value, .. } => format!("CAM21 write {index:04X}:{sub:02X} = {value:X}"),
        },
        Payload::Cam11(r) => match r {
            CamResponse::Read { index, sub, value, .. } => format!("CAM11 {index:04X}:{sub:02X} = {value:X}"),
            CamResponse::Written { index, sub } => format!("CAM11 {index:04X}:{sub:02X} written"),
            CamResponse::Abort { index, sub, code } => format!("CAM11 abort {index:04X}:{sub:02X} code {code:08X}"),
        },
        Payload::Epos(e) => format!("EPOS position={}", e.position),
        Payload::Espd(e) => format!("ESPD speed={} Inc/ms", e.speed),
        Payload::ProprietaryB(b) => format!("Proprietary B position={} speed={}", b.position, b.speed),
        Payload::Emcy(e) => {
            let reset = if e.code == 0 { " (error reset)" } else { "" };
            format!("EMCY {:04X} register {:02X}{reset}", e.code, e.register)
        }
        Payload::Other => format!("PGN {pgn} ({pgn:05X}h)"),
    };
    format!("{from}{to} {what}")
}
