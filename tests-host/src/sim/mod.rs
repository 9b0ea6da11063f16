//! The real-time simulator behind the `sim` binary: the SIKO devices on simulated CAN buses,
//! served over the socketcand protocol (see README.md and `sim --help`).

pub mod decode;
pub mod devices;
pub mod j1939;
pub mod master;
pub mod options;
pub mod run;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod socketcand;
