//! Parameter access over CAM21/CAM11 (CiA 510 as the WV58MR manual §5.5 uses it; D-J1939-2,
//! D-J1939-12): which CAM21 frames the node hands to its SDO server, and how the server's
//! 8-byte answer goes back.
//!
//! The SDO protocol itself (expedited read and write, CiA 301 aborts, 1010h/1011h) is the
//! core's SDO server, the same one that serves 600h/580h on CANopen; this module only does the
//! J1939 addressing around it.

use crate::frame::Frame;
use crate::wire::j1939::{cam11_frame, Address, Identifier, Pgn};

/// If the message `id` with `len` data bytes is a parameter-access request the CA at `own`
/// answers, the requester's address: CAM21, to our address (not the global one), from a
/// unicast address, 8 data bytes, and only once our claim stood (`own` is
/// [`crate::j1939::claim::AddressClaimer::source_address`]).
pub fn requester(id: &Identifier, len: usize, own: Option<Address>) -> Option<Address> {
    let own = own?;
    let ok = id.pgn() == Pgn::CAM21 && id.destination() == Some(own) && id.source().is_unicast() && len == 8;
    if ok {
        Some(id.source())
    } else {
        None
    }
}

/// Is the 29-bit identifier `raw` (of a data frame) a CAM21 message (EDP, DP and PF 006h, any
/// priority and addresses)? The bits above 28 must be clear, as [`Identifier::parse`] wants.
#[inline]
pub const fn is_cam21(raw: u32) -> bool {
    raw & 0xE3FF_0000 == Pgn::CAM21.raw() << 8
}

/// [`requester`] of a data frame whose identifier `raw` [`is_cam21`], read off the raw
/// identifier: the source address, if the destination is `own` and the source unicast.
#[inline]
pub fn cam21_requester(raw: u32, len: usize, own: Option<Address>) -> Option<Address> {
    let (da, sa) = (Address((raw >> 8) as u8), Address(raw as u8));
    if Some(da) == own && sa.is_unicast() && len == 8 {
        Some(sa)
    } else {
        None
    }
}

/// The CAM11 frame with the SDO server's `reply` from `own` to `requester`.
pub fn answer(reply: &[u8; 8], requester: Address, own: Address) -> Frame {
    cam11_frame(reply, requester, own)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::CanId;
    use crate::wire::j1939::{CamRequest, CamResponse, Priority};

    const OWN: Option<Address> = Some(Address(0xEF));

    fn id(raw: u32) -> Identifier {
        Identifier::parse(raw).unwrap()
    }

    #[test]
    fn e1_request_is_accepted_and_answered_to_the_requester() {
        let f = CamRequest::Read { index: 0x6003, sub: 0 }.frame(Address(0xEF), Address(0x00));
        let rq = requester(&Identifier::from_frame(&f).unwrap(), f.payload().len(), OWN);
        assert_eq!(rq, Some(Address(0x00)));
        let reply = [0x43, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00];
        assert_eq!(answer(&reply, Address(0x00), Address(0xEF)), Frame::new(CanId::Ext(0x1C05_00EF), &reply));
        let typed = CamResponse::Read { index: 0x6003, sub: 0, value: 0x1FE, len: 4 };
        assert_eq!(typed.frame(Address(0x00), Address(0xEF)), Frame::new(CanId::Ext(0x1C05_00EF), &reply));
    }

    /// The raw reading takes exactly the CAM21 messages, and of them exactly the requests
    /// [`requester`] takes, over identifiers near CAM21 and random ones.
    #[test]
    fn the_raw_reading_is_the_parsed_one() {
        let mut x = 1u32;
        for n in 0..200_000u32 {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let raw = match n % 4 {
                0 => x,
                1 => x & 0x1FFF_FFFF,
                // CAM21 at any priority and addresses, EDP/DP/PF bits flipped now and then.
                2 => (x & 0x1C00_FFFF) | 0x0006_0000 ^ ((x << 8) & 0x0301_0000 & (x << 3)),
                _ => (x & 0x1C00_00FF) | 0x0006_0000 | [0xEF, 0xFF, 0x00, 0xEE][(x >> 20) as usize % 4] << 8,
            };
            let (len, own) = ((x >> 9) as usize % 9, [OWN, None, Some(Address(0))][(x >> 13) as usize % 3]);
            let parsed = Identifier::parse(raw).ok().and_then(|id| requester(&id, len, own));
            let quick = if is_cam21(raw) { cam21_requester(raw, len, own) } else { None };
            assert_eq!(quick, parsed, "{raw:08X} len {len} own {own:?}");
            assert_eq!(is_cam21(raw), Identifier::parse(raw).is_ok_and(|id| id.pgn() == Pgn::CAM21), "{raw:08X}");
        }
    }

    #[test]
    fn other_requests_are_not_for_the_sdo_server() {
        assert_eq!(requester(&id(0x1C06_EF00), 8, None), None, "claim not yet stood");
        assert_eq!(requester(&id(0x1C06_4A00), 8, OWN), None, "another device");
        assert_eq!(requester(&id(0x1C06_FF00), 8, OWN), None, "global");
        assert_eq!(requester(&id(0x1C06_EFFE), 8, OWN), None, "from the null address");
        assert_eq!(requester(&id(0x1C06_EF00), 7, OWN), None, "DLC 7");
        assert_eq!(requester(&id(0x1C05_EF00), 8, OWN), None, "CAM11 is an answer");
        // Any priority is accepted (J1939 receivers do not filter on it).
        let low = Identifier::pdu1(Priority::HIGHEST, Pgn::CAM21, Address(0xEF), Address(0x21)).unwrap();
        assert_eq!(requester(&low, 8, OWN), Some(Address(0x21)));
    }
}
