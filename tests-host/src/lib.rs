//! Host-side harness for the SIKO devices: a virtual CAN bus with a virtual clock on which
//! scenario tests replay the manuals' examples, and (in `sim`) the real-time simulator.

pub mod ap10t;
pub mod bench;
pub mod bus;
pub mod eds;
pub mod encoder;
pub mod flash;
pub mod invariants;
pub mod j1939;
pub mod segment;
pub mod sim;

use od_core::node::{CanopenDevice, Device};
use od_core::od::Entry;

/// A device with a dictionary and no behaviour of its own: what the communication-profile
/// tests need before a device profile is involved. It keeps the `Device` defaults: the SIKO
/// bit-rate codes of 5F0Ah.02 and an LSS slave (right for the SGH10, SGH50 and WV5800M tables).
pub struct TableOnly(pub &'static [Entry]);

impl Device for TableOnly {
    fn table(&self) -> &'static [Entry] {
        self.0
    }
}

impl CanopenDevice for TableOnly {}
