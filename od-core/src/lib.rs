//! `od-core`: the sans-IO CANopen and J1939 core that every SIKO firmware links.
//!
//! It owns every protocol decision and nothing else: it never waits, never touches hardware,
//! keeps no global state and takes time as an argument. The firmware, the host tests and the
//! simulator are thin shells that move frames in and [`context::Output`]s out.
#![no_std]
#![deny(missing_docs)]

pub mod abort;
pub mod access;
pub mod arith;
pub mod autobaud;
pub mod bitrate;
pub mod context;
pub mod device;
pub mod devices;
pub mod emcy;
pub mod encoder;
pub mod errors;
pub mod frame;
pub mod guarding;
pub mod heartbeat;
pub mod j1939;
pub mod led;
pub mod lookup;
pub mod lss;
pub mod nmt;
pub mod node;
pub mod od;
pub mod output;
pub mod pdo;
pub mod sdo;
pub mod shell;
pub mod storage;
pub mod time;
pub mod wire;

pub use abort::Abort;
pub use bitrate::Bitrate;
pub use context::{BusEvent, Context, Output};
pub use device::{CanopenDevice, Device};
pub use frame::{CanId, Frame, RxId};
pub use nmt::NmtState;
pub use node::Node;
pub use shell::{DeviceStation, Station};
pub use time::{Duration, Instant};
