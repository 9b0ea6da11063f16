//! WV5800M / WH5800M multiturn rotary encoder (CANopen, CiA 301 + CiA 406, LSS). The part
//! number is a build option: `cargo firmware --features wh,turns-256` (default WV5800M, 4096
//! turns).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use od_core::devices::wv5800m::{table_of, Model, Turns, Variant, Wv5800m};
use panic_probe as _;

#[cfg(any(
    all(feature = "turns-256", feature = "turns-16"),
    all(feature = "turns-256", feature = "singleturn"),
    all(feature = "turns-16", feature = "singleturn"),
))]
compile_error!("choose at most one of the features turns-256, turns-16, singleturn");

/// The part number this image is built for.
const VARIANT: Variant = Variant {
    model: if cfg!(feature = "wh") { Model::Wh } else { Model::Wv },
    turns: if cfg!(feature = "singleturn") {
        Turns::Single
    } else if cfg!(feature = "turns-16") {
        Turns::Multi4
    } else if cfg!(feature = "turns-256") {
        Turns::Multi8
    } else {
        Turns::Multi12
    },
};

/// The identity this device's parameter images carry, computed when the image is built.
const IDENTITY: u32 = od_core::storage::identity(table_of(VARIANT));

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    firmware::boot_time::start();
    let board = boards::wv5800m::take(VARIANT);
    firmware::run::run(Wv5800m::new(VARIANT), IDENTITY, board.mcu, board.io).await
}
