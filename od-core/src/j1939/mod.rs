//! SAE J1939 services: the state machines and policies a J1939 node is built from, each pure
//! and sans-IO over the [`crate::wire::j1939`] formats, time passed in as
//! [`crate::time::Instant`], frames returned as values, no allocation.
//!
//! - [`claim`]: address claiming per J1939-81, the NAME contest, Cannot Claim, the 250 ms
//!   before other traffic, and the green LED while claiming;
//! - [`request`]: what the node does with a Request (PGN 59904): send the group, NACK, or stay
//!   silent;
//! - [`led`]: the three LEDs of a WV58MR channel;
//! - [`param`]: the J1939 addressing around the SDO server for CAM21/CAM11;
//! - [`rx`]: the frames a node receives, as acceptance filters;
//! - [`schedule`]: cyclic transmission of the process-data groups at their cycle times and
//!   priorities (3000h).

pub mod claim;
pub mod led;
pub mod param;
pub mod request;
pub mod rx;
pub mod schedule;
