//! NMT (CiA 301 §7.2.8.3.1): the module-control command (2 bytes on 000h) and the one-byte
//! error-control message (boot-up, heartbeat and node-guarding answer on 700h + node-ID).

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

/// An NMT module-control message: command and target node-ID (0 = all nodes).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct NmtRequest {
    /// The command.
    pub command: NmtCommand,
    /// Target node-ID; 0 addresses every node.
    pub node: u8,
}

impl NmtRequest {
    /// Parses the data bytes of an NMT frame; `None` for anything but two bytes with a known
    /// command (CiA 301 has no error response for NMT: such a frame is ignored).
    pub fn parse(data: &[u8]) -> Option<NmtRequest> {
        let [cs, node] = data.try_into().ok()?;
        Some(NmtRequest { command: NmtCommand::from_cs(cs)?, node })
    }

    /// The data bytes a master sends.
    pub const fn emit(&self) -> [u8; 2] {
        [self.command.cs(), self.node]
    }

    /// Does it address the node with `node_id`?
    pub const fn addresses(&self, node_id: u8) -> bool {
        self.node == 0 || self.node == node_id
    }
}

/// The state code of the boot-up message.
pub const BOOT_UP: u8 = 0x00;

/// An error-control message: the NMT state code (bits 6..0: 00h boot-up, 04h STOPPED, 05h
/// OPERATIONAL, 7Fh PRE-OPERATIONAL) and, in a node-guarding answer, the toggle bit (bit 7;
/// always 0 in boot-up and heartbeat messages).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct ErrorControl {
    /// The state code (0..=7Fh).
    pub state: u8,
    /// The node-guarding toggle bit.
    pub toggle: bool,
}

impl ErrorControl {
    /// Parses the one data byte; `None` for any other length.
    pub fn parse(data: &[u8]) -> Option<ErrorControl> {
        let [b] = data.try_into().ok()?;
        Some(ErrorControl { state: b & 0x7F, toggle: b & 0x80 != 0 })
    }

    /// The data byte (a state code above 7Fh is cut to its 7 bits).
    pub const fn emit(&self) -> [u8; 1] {
        [(self.state & 0x7F) | if self.toggle { 0x80 } else { 0 }]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn module_control_byte_by_byte() {
        for cs in [0x01, 0x02, 0x80, 0x81, 0x82] {
            let r = NmtRequest::parse(&[cs, 5]).unwrap();
            assert_eq!(r.command.cs(), cs);
            assert_eq!(r.emit(), [cs, 5]);
            assert!(r.addresses(5) && !r.addresses(6));
        }
        assert!(NmtRequest::parse(&[0x01, 0]).unwrap().addresses(77));
    }

    #[test]
    fn malformed_module_control_is_ignored() {
        assert_eq!(NmtRequest::parse(&[]), None);
        assert_eq!(NmtRequest::parse(&[0x01]), None);
        assert_eq!(NmtRequest::parse(&[0x01, 1, 0]), None);
        for cs in [0x00, 0x03, 0x7F, 0x83, 0xFF] {
            assert_eq!(NmtRequest::parse(&[cs, 1]), None, "{cs:02X}");
        }
    }

    #[test]
    fn error_control_byte_by_byte() {
        assert_eq!(ErrorControl { state: BOOT_UP, toggle: false }.emit(), [0x00]);
        assert_eq!(ErrorControl { state: 0x7F, toggle: true }.emit(), [0xFF]);
        assert_eq!(ErrorControl { state: 0x05, toggle: false }.emit(), [0x05]);
        assert_eq!(ErrorControl::parse(&[0x84]), Some(ErrorControl { state: 0x04, toggle: true }));
        assert_eq!(ErrorControl::parse(&[]), None);
        assert_eq!(ErrorControl::parse(&[0x05, 0]), None);
        for b in 0..=255u8 {
            assert_eq!(ErrorControl::parse(&[b]).unwrap().emit(), [b]);
        }
    }
}
