//! What a J1939 node does with a Request, PGN 59904 (J1939-21; D-J1939-9 on WV58MR A28).
//!
//! [`respond`] is a pure decision over the request's identifier and payload, the node's
//! claimed address and the groups it provides:
//! - a Request for Address Claimed goes to the address claimer
//!   ([`crate::j1939::claim::AddressClaimer`]), which answers it even while still contending;
//! - nothing else is answered before the claim has stood (no source address yet), nor a
//!   request from the null address or from FFh (no CA's source address), nor one to another
//!   CA;
//! - a group the node provides is sent (a broadcast group as usual, a destination-specific one
//!   to the requester);
//! - a request to our address for a group we do not provide gets a NACK (PGN 59392, to the
//!   global address with the requester in the address field); a global one is not answered,
//!   as J1939-21 forbids a NACK to a global request.

use crate::frame::Frame;
use crate::wire::j1939::{Acknowledgement, Address, Identifier, Pgn, Request};

/// The node's answer to a received message, if it is a Request.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Response {
    /// Nothing to send: not a request, not for us, malformed, or a global request for a group
    /// we do not provide.
    Ignore,
    /// A Request for Address Claimed: hand the message to the address claimer.
    AddressClaim,
    /// Send the requested group now, with its current content.
    Send {
        /// The group.
        pgn: Pgn,
        /// The destination of a destination-specific (PDU1) group: the requester, or the global
        /// address for a global request; `None` for a broadcast group.
        destination: Option<Address>,
    },
    /// Send this NACK.
    Nack(Frame),
}

/// Decide what to do with the message `id`/`data`. `own`: our source address once the claim
/// stood ([`crate::j1939::claim::AddressClaimer::source_address`]); `provided`: the groups the
/// node sends (the WV58MR: EPOS, ESPD and Proprietary B).
pub fn respond(id: &Identifier, data: &[u8], own: Option<Address>, provided: &[Pgn]) -> Response {
    if id.pgn() != Pgn::REQUEST {
        return Response::Ignore;
    }
    let Ok(req) = Request::parse(data) else {
        return Response::Ignore;
    };
    if req.pgn == Pgn::ADDRESS_CLAIMED {
        return Response::AddressClaim;
    }
    let Some(own) = own else {
        return Response::Ignore;
    };
    let requester = id.source();
    let destination = id.destination().unwrap_or(Address::GLOBAL);
    if !requester.is_unicast() || (destination != Address::GLOBAL && destination != own) {
        return Response::Ignore;
    }
    if provided.contains(&req.pgn) {
        let destination = if !req.pgn.is_pdu1() {
            None
        } else if destination == Address::GLOBAL {
            Some(Address::GLOBAL)
        } else {
            Some(requester)
        };
        Response::Send { pgn: req.pgn, destination }
    } else if destination == own {
        Response::Nack(Acknowledgement::nack(req.pgn, requester).frame(own))
    } else {
        Response::Ignore
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::CanId;
    use crate::wire::j1939::Priority;

    const PROVIDED: [Pgn; 3] = [Pgn::EPOS, Pgn::ESPD, Pgn::PROPRIETARY_B];
    const OWN: Option<Address> = Some(Address(0xEF));

    fn req(da: u8, sa: u8, pgn: u32) -> (Identifier, [u8; 3]) {
        let id = Identifier::pdu1(Priority::DEFAULT, Pgn::REQUEST, Address(da), Address(sa)).unwrap();
        (id, Pgn::new(pgn).unwrap().to_le_bytes())
    }

    fn run(da: u8, sa: u8, pgn: u32, own: Option<Address>) -> Response {
        let (id, data) = req(da, sa, pgn);
        respond(&id, &data, own, &PROVIDED)
    }

    #[test]
    fn provided_groups_are_sent_to_global_and_direct_requests() {
        for pgn in [64607, 64609, 65450] {
            for da in [0xFF, 0xEF] {
                assert_eq!(run(da, 0x00, pgn, OWN), Response::Send { pgn: Pgn::new(pgn).unwrap(), destination: None });
            }
        }
    }

    #[test]
    fn unknown_groups_are_nacked_when_asked_directly_and_ignored_globally() {
        // EMCY is sent on events only, CAM11 only as an answer: neither can be requested.
        for pgn in [64616, 1280, 0xFEEE] {
            assert_eq!(run(0xFF, 0x00, pgn, OWN), Response::Ignore, "{pgn}");
            let Response::Nack(f) = run(0xEF, 0x21, pgn, OWN) else { panic!("{pgn}: no NACK") };
            let p = Pgn::new(pgn).unwrap().to_le_bytes();
            assert_eq!(f, Frame::new(CanId::Ext(0x18E8_FFEF), &[0x01, 0xFF, 0xFF, 0xFF, 0x21, p[0], p[1], p[2]]));
        }
    }

    #[test]
    fn destination_specific_groups_go_back_to_the_requester() {
        let provided = [Pgn::CAM11];
        let (id, data) = req(0xEF, 0x21, 1280);
        assert_eq!(
            respond(&id, &data, OWN, &provided),
            Response::Send { pgn: Pgn::CAM11, destination: Some(Address(0x21)) }
        );
        let (id, data) = req(0xFF, 0x21, 1280);
        assert_eq!(
            respond(&id, &data, OWN, &provided),
            Response::Send { pgn: Pgn::CAM11, destination: Some(Address::GLOBAL) }
        );
    }

    #[test]
    fn address_claimed_goes_to_the_claimer_even_without_an_address() {
        assert_eq!(run(0xFF, 0xFE, 60928, None), Response::AddressClaim);
        assert_eq!(run(0x80, 0x00, 60928, OWN), Response::AddressClaim);
    }

    #[test]
    fn silent_before_the_claim_stood_for_others_and_for_the_null_address() {
        assert_eq!(run(0xEF, 0x00, 64607, None), Response::Ignore);
        assert_eq!(run(0xEF, 0x00, 0xFEEE, None), Response::Ignore);
        assert_eq!(run(0x80, 0x00, 64607, OWN), Response::Ignore);
        assert_eq!(run(0x80, 0x00, 0xFEEE, OWN), Response::Ignore);
        assert_eq!(run(0xEF, 0xFE, 0xFEEE, OWN), Response::Ignore);
    }

    /// Found by the J1939 invariant proptest: a request "from" FFh, the global address, which no
    /// CA can send from, was NACKed as if FFh were a requester.
    #[test]
    fn a_request_from_the_global_address_is_not_answered() {
        assert_eq!(run(0xEF, 0xFF, 0xFEEE, OWN), Response::Ignore);
        assert_eq!(run(0xEF, 0xFF, 1280, OWN), Response::Ignore);
        assert_eq!(run(0xFF, 0xFF, 64607, OWN), Response::Ignore);
    }

    #[test]
    fn other_messages_and_malformed_requests_are_ignored() {
        let (id, _) = req(0xEF, 0, 64607);
        assert_eq!(respond(&id, &[0x5F, 0xFC], OWN, &PROVIDED), Response::Ignore);
        assert_eq!(respond(&id, &[0x01, 0xEA, 0x00], OWN, &PROVIDED), Response::Ignore);
        let epos = Identifier::pdu2(Priority::DEFAULT, Pgn::EPOS, Address(0x10)).unwrap();
        assert_eq!(respond(&epos, &[0x5F, 0xFC, 0x00], OWN, &PROVIDED), Response::Ignore);
    }
}
