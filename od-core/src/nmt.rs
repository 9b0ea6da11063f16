//! NMT slave (CiA 301 §7.2.8): the states, the command frame, and what each state allows.

use crate::frame::{CanId, Frame};

/// NMT state of a node.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum NmtState {
    /// Initialisation: the node takes no part in bus traffic until its boot-up is sent.
    Initialising,
    /// Pre-operational: SDO, EMCY, heartbeat and guarding; no PDO.
    PreOperational,
    /// Operational: everything.
    Operational,
    /// Stopped: only NMT, heartbeat and node guarding (and LSS).
    Stopped,
}

impl NmtState {
    /// The state code in heartbeat and node-guarding frames (0, 7Fh, 05h, 04h).
    pub const fn code(self) -> u8 {
        match self {
            NmtState::Initialising => 0x00,
            NmtState::PreOperational => 0x7F,
            NmtState::Operational => 0x05,
            NmtState::Stopped => 0x04,
        }
    }

    /// SDO transfers are served (not in STOPPED).
    pub const fn sdo_allowed(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }

    /// EMCY frames may be sent (not in STOPPED, as every manual says).
    pub const fn emcy_allowed(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }

    /// PDOs are sent and received (OPERATIONAL only).
    pub const fn pdo_allowed(self) -> bool {
        matches!(self, NmtState::Operational)
    }
}

/// An NMT command specifier.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum NmtCommand {
    /// 01h: start remote node.
    Start,
    /// 02h: stop remote node.
    Stop,
    /// 80h: enter pre-operational.
    EnterPreOperational,
    /// 81h: reset node.
    ResetNode,
    /// 82h: reset communication.
    ResetCommunication,
}

impl NmtCommand {
    /// The command byte.
    pub const fn cs(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
        }
    }

    /// Parses a command byte.
    pub const fn from_cs(cs: u8) -> Option<NmtCommand> {
        Some(match cs {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            _ => return None,
        })
    }
}

/// An NMT master frame: COB-ID 000h, command and target node-ID (0 = all nodes).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct NmtRequest {
    /// The command.
    pub command: NmtCommand,
    /// Target node-ID; 0 addresses every node.
    pub node: u8,
}

impl NmtRequest {
    /// Parses an NMT frame; `None` for anything that is not a well-formed NMT command
    /// (wrong identifier, remote frame, DLC other than 2, unknown command): CiA 301 has no
    /// error response for NMT, such a frame is ignored.
    pub fn parse(frame: &Frame) -> Option<NmtRequest> {
        if frame.id != CanId::Std(0) || frame.rtr || frame.len != 2 {
            return None;
        }
        Some(NmtRequest { command: NmtCommand::from_cs(frame.data[0])?, node: frame.data[1] })
    }

    /// The frame a master sends.
    pub fn emit(&self) -> Frame {
        Frame::std(0, &[self.command.cs(), self.node])
    }

    /// Does it address the node with `node_id`?
    pub const fn addresses(&self, node_id: u8) -> bool {
        self.node == 0 || self.node == node_id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_emit_round_trip() {
        for cs in [0x01, 0x02, 0x80, 0x81, 0x82] {
            let f = Frame::std(0, &[cs, 5]);
            let r = NmtRequest::parse(&f).unwrap();
            assert_eq!(r.emit(), f);
            assert!(r.addresses(5) && !r.addresses(6));
        }
    }

    #[test]
    fn malformed_nmt_frames_are_ignored() {
        assert_eq!(NmtRequest::parse(&Frame::std(0, &[0x01])), None);
        assert_eq!(NmtRequest::parse(&Frame::std(0, &[0x01, 1, 0])), None);
        assert_eq!(NmtRequest::parse(&Frame::std(0, &[0x03, 1])), None);
        assert_eq!(NmtRequest::parse(&Frame::std(1, &[0x01, 1])), None);
        assert_eq!(NmtRequest::parse(&Frame::remote(CanId::Std(0), 2)), None);
        assert!(NmtRequest::parse(&Frame::std(0, &[0x01, 0])).unwrap().addresses(77));
    }
}
