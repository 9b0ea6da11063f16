//! J1939 stations for the virtual bus: a [`J1939Node`] fed by a [`crate::encoder::Sensor`], the master's CAM21
//! requests, and helpers to read frames by their J1939 fields.

use od_core::encoder::Encoder;
use od_core::j1939::node::{J1939Device, J1939Node};
use od_core::wire::j1939::{Address, CamRequest, Identifier, Pgn};
use od_core::Frame;

use crate::bus::{Bus, Station};
use crate::encoder::SensedNode;

/// A J1939 node of encoder `E` with a sampled [`crate::encoder::Sensor`], as a bus station.
pub type SensedJ1939<E> = SensedNode<J1939Node<E>>;

impl<E: Encoder + J1939Device> Station for SensedJ1939<E> {
    fn panel(&self) -> Option<String> {
        let l = self.node.leds();
        Some(format!("green={:?} red={:?} yellow={:?}", l.green, l.red, l.yellow))
    }
}

/// The raw 29-bit identifier of a frame (0 for an 11-bit one).
pub fn raw_id(frame: &Frame) -> u32 {
    match frame.id {
        od_core::CanId::Ext(id) => id,
        od_core::CanId::Std(_) => 0,
    }
}

/// The frames of group `pgn` among `frames`, with the instant each was seen.
pub fn of_group(frames: &[crate::bus::Seen], pgn: Pgn) -> Vec<crate::bus::Seen> {
    frames.iter().filter(|s| Identifier::from_frame(&s.frame).map(|i| i.pgn()) == Ok(pgn)).copied().collect()
}

/// Sends a CAM21 request from `master` to `device` and returns every frame the bus carried
/// until the answer, and the answer's 8 bytes (CAM11 from `device` to `master`).
pub fn cam_exchange(bus: &mut Bus, device: Address, master: Address, data: [u8; 8]) -> (Vec<Frame>, [u8; 8]) {
    bus.send(Frame::new(od_core::CanId::Ext(0x1C06_0000 | (device.0 as u32) << 8 | master.0 as u32), &data));
    let answer = 0x1C05_0000 | (master.0 as u32) << 8 | device.0 as u32;
    let mut seen = Vec::new();
    for _ in 0..1000 {
        while let Some(s) = bus.recv() {
            seen.push(s.frame);
            if raw_id(&s.frame) == answer {
                let mut b = [0; 8];
                b.copy_from_slice(s.frame.payload());
                return (seen, b);
            }
        }
        bus.advance(1);
    }
    panic!("no CAM11 answer from {device:?}; saw {seen:02X?}");
}

/// Reads (index, sub) over CAM21/CAM11: the answer's bytes.
pub fn cam_read(bus: &mut Bus, device: Address, master: Address, index: u16, sub: u8) -> [u8; 8] {
    cam_exchange(bus, device, master, CamRequest::Read { index, sub }.emit()).1
}
