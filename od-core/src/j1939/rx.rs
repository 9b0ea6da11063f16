//! The frames a J1939 node receives, as extended-identifier acceptance filters (identifier and
//! mask over the 29 bits) for a CAN controller, a function of the address the node claims.
//!
//! The priority bits are never compared (J1939-21: a receiver must not depend on the priority);
//! EDP and DP are (they are part of the PGN, D-J1939-11). A node receives:
//! - Requests to the global address and to its own address (PGN 59904);
//! - every Address Claimed / Cannot Claim (PGN 60928), whatever its destination and source,
//!   to keep its table of taken addresses;
//! - CAM21 parameter-access requests to its own address (PGN 1536).

use crate::wire::j1939::{Address, Pgn};

/// One acceptance filter: a frame with 29-bit identifier `raw` passes when
/// `raw & mask == id & mask`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Filter {
    /// The identifier bits to match.
    pub id: u32,
    /// Which bits must match.
    pub mask: u32,
}

impl Filter {
    /// Does the identifier `raw` pass?
    pub const fn matches(&self, raw: u32) -> bool {
        raw & self.mask == self.id & self.mask
    }
}

/// EDP, DP, PF and PS.
const PGN_AND_DA: u32 = 0x03FF_FF00;
/// EDP, DP and PF.
const PGN_ONLY: u32 = 0x03FF_0000;

const fn pdu1_to(pgn: Pgn, da: Address) -> Filter {
    Filter { id: pgn.raw() << 8 | (da.0 as u32) << 8, mask: PGN_AND_DA }
}

/// The filters for a node at `own` (`None`: no address yet or Cannot Claim; then only the
/// global Requests and the claims pass). Unused slots of the array repeat the first filter, so
/// a controller with four filter banks takes the array as it is.
pub const fn filters(own: Option<Address>) -> [Filter; 4] {
    let global = pdu1_to(Pgn::REQUEST, Address::GLOBAL);
    let claims = Filter { id: Pgn::ADDRESS_CLAIMED.raw() << 8, mask: PGN_ONLY };
    match own {
        Some(a) => [global, claims, pdu1_to(Pgn::REQUEST, a), pdu1_to(Pgn::CAM21, a)],
        None => [global, claims, global, global],
    }
}

/// Does a frame with identifier `raw` pass any of `filters`?
pub fn accepts(filters: &[Filter], raw: u32) -> bool {
    filters.iter().any(|f| f.matches(raw))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_node_at_ef_receives_what_it_must_and_nothing_it_need_not() {
        let f = filters(Some(Address(0xEF)));
        for raw in [
            0x18EA_FF00u32, // Request to global
            0x18EA_EF21,    // Request to us
            0x18EA_FFFE,    // Request for Address Claimed from the null address
            0x18EE_FF80,    // a claim
            0x18EE_FFFE,    // Cannot Claim
            0x18EE_2180,    // a claim to a requester
            0x1C06_EF00,    // E1
            0x0006_EF00,    // CAM21 at priority 0
        ] {
            assert!(accepts(&f, raw), "{raw:08X}");
        }
        for raw in [
            0x1C06_4A00u32, // CAM21 to another device
            0x1C05_00EF,    // CAM11
            0x18EA_8000,    // Request to another device
            0x0CFC_5F80,    // EPOS of another device
            0x18E8_FF80,    // NACK
            0x1DEA_FF00,    // Request with DP set
            0x1EEE_FF80,    // Address Claimed with EDP set
        ] {
            assert!(!accepts(&f, raw), "{raw:08X}");
        }
    }

    #[test]
    fn without_an_address_only_global_requests_and_claims_pass() {
        let f = filters(None);
        assert!(accepts(&f, 0x18EA_FF00) && accepts(&f, 0x18EE_FF80));
        assert!(!accepts(&f, 0x18EA_EF00) && !accepts(&f, 0x1C06_EF00));
    }
}
