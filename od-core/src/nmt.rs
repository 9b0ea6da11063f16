//! NMT slave (CiA 301 §7.2.8): the states and what each state allows. The command and
//! error-control messages are [`crate::wire::nmt`]'s.

pub use crate::wire::nmt::{NmtCommand, NmtRequest};

/// NMT state of a node. Each state is stored as its code in heartbeat and node-guarding
/// frames ([`NmtState::code`] is a plain read).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
pub enum NmtState {
    /// Initialisation: the node takes no part in bus traffic until its boot-up is sent.
    Initialising = 0x00,
    /// Pre-operational: SDO, EMCY, heartbeat and guarding; no PDO.
    PreOperational = 0x7F,
    /// Operational: everything.
    Operational = 0x05,
    /// Stopped: only NMT, heartbeat and node guarding (and LSS).
    Stopped = 0x04,
}

impl NmtState {
    /// The state code in heartbeat and node-guarding frames (0, 7Fh, 05h, 04h).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// SDO transfers are served (not in STOPPED).
    pub const fn sdo_allowed(self) -> bool {
        // PRE-OPERATIONAL (7Fh) and OPERATIONAL (05h) are the odd codes.
        self as u8 & 1 != 0
    }

    /// EMCY frames may be sent (not in STOPPED, as every manual says).
    pub const fn emcy_allowed(self) -> bool {
        // PRE-OPERATIONAL (7Fh) and OPERATIONAL (05h) are the odd codes.
        self as u8 & 1 != 0
    }

    /// PDOs are sent and received (OPERATIONAL only).
    pub const fn pdo_allowed(self) -> bool {
        matches!(self, NmtState::Operational)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The codes the heartbeat and guarding send, and what each state allows (CiA 301).
    #[test]
    fn codes_and_permissions() {
        use NmtState::*;
        let table = [
            (Initialising, 0x00, false, false),
            (PreOperational, 0x7F, true, false),
            (Operational, 0x05, true, true),
            (Stopped, 0x04, false, false),
        ];
        for (state, code, sdo, pdo) in table {
            assert_eq!(state.code(), code, "{state:?}");
            assert_eq!((state.sdo_allowed(), state.emcy_allowed(), state.pdo_allowed()), (sdo, sdo, pdo), "{state:?}");
        }
    }
}
