//! SAE J1939 services: the state machines and policies a J1939 node is built from, each pure
//! and sans-IO over the [`crate::wire::j1939`] formats, time passed in as
//! [`crate::time::Instant`], frames returned as values, no allocation.
//!
//! - [`claim`]: address claiming per J1939-81, the NAME contest, Cannot Claim, the 250 ms
//!   before other traffic, and the green LED while claiming;
//! - [`request`]: what the node does with a Request (PGN 59904): send the group, NACK, or stay
//!   silent;
//! - [`led`]: the three LEDs of a WV58MR channel;
//! - [`node`]: the J1939 node that puts them together over the transport-neutral context and a
//!   device, behind the shell trait (`crate::shell::Station`);
//! - [`param`]: the J1939 addressing around the SDO server for CAM21/CAM11;
//! - [`rx`]: the frames a node receives, as acceptance filters;
//! - [`schedule`]: cyclic transmission of the process-data groups at their cycle times and
//!   priorities (3000h).
//!
//! How a node puts them together ([`node::J1939Node`] does this over the dictionary, with the
//! SDO server behind CAM21/CAM11), in miniature:
//!
//! ```
//! use od_core::j1939::{claim::AddressClaimer, request, schedule::{Cyclic, Scheduler}};
//! use od_core::wire::j1939::{Address, Epos, Identifier, Message, Name, Pgn, Priority};
//! use od_core::Instant;
//!
//! let name = Name::from_raw(0xB000_8E00_8E20_0001);
//! let mut claim = AddressClaimer::new(name, Address(0xEF), 0x80, 0xEF);
//! let p = |n| Priority::new(n).unwrap();
//! let mut cyclic = Scheduler::new([
//!     Cyclic::new(Pgn::PROPRIETARY_B, 0, p(6)),
//!     Cyclic::new(Pgn::ESPD, 50, p(3)),
//!     Cyclic::new(Pgn::EPOS, 50, p(3)),
//! ]);
//! let mut bus = Vec::new();
//!
//! bus.push(claim.start(Instant::ZERO)); // 18EEFFEF: Address Claimed
//! let mut now = Instant::ZERO;
//! while let Some(t) = od_core::time::earliest(claim.next_deadline(), cyclic.next_deadline()) {
//!     if t > Instant::from_millis(300) {
//!         break;
//!     }
//!     now = t;
//!     bus.extend(claim.poll(now));
//!     match (claim.source_address(), cyclic.is_running()) {
//!         (Some(_), false) => cyclic.start(now), // the claim stood 250 ms
//!         (None, true) => cyclic.stop(),         // the address was lost
//!         _ => {}
//!     }
//!     while let Some(due) = cyclic.poll(now) {
//!         let sa = claim.source_address().unwrap();
//!         let id = Identifier::pdu2(due.priority, due.pgn, sa).unwrap();
//!         if due.pgn == Pgn::EPOS {
//!             bus.push(id.frame(&Epos { position: 0x12345 }.emit()));
//!         }
//!     }
//! }
//! // EPOS at 250 and 300 ms.
//! let epos: Vec<_> = bus.iter().filter_map(|f| Message::parse(f).ok()).filter(|m| m.id.pgn() == Pgn::EPOS).collect();
//! assert_eq!(epos.len(), 2);
//!
//! // A Request for EPOS to our address is answered with EPOS; one for another group, a NACK.
//! let rq = od_core::wire::j1939::Request { pgn: Pgn::EPOS }.frame(Address(0xEF), Address(0x21));
//! let id = Identifier::from_frame(&rq).unwrap();
//! let provided = [Pgn::EPOS, Pgn::ESPD, Pgn::PROPRIETARY_B];
//! assert_eq!(
//!     request::respond(&id, rq.payload(), claim.source_address(), &provided),
//!     request::Response::Send { pgn: Pgn::EPOS, destination: None }
//! );
//! # let _ = now;
//! ```

pub mod claim;
pub mod led;
pub mod node;
pub mod param;
pub mod request;
pub mod rx;
pub mod schedule;

#[cfg(test)]
mod tests;
