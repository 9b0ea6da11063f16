//! WV58MR / WH58MR absolute redundant rotary encoder with SAE J1939 interface (SIKO manual
//! 81/25): its dictionary ([`table`]) and its behaviour.
//!
//! The device is two encoders in one housing (§2), each a J1939 ECU with its own LEDs, NAME
//! and dictionary (D-J1939-13, D-J1939-17): firmware builds one channel, a redundant pair is two
//! of them with different serial numbers.

pub mod table;

pub use table::{hooks, table_of, DEFAULT_ADDRESS, DEFAULT_BITRATE_CODE, ENTRIES, HIGHEST_ADDRESS, LOWEST_ADDRESS};
