//! WV58MR / WH58MR redundant rotary encoder, one channel (SAE J1939, CiA 406-J). Each channel
//! of the redundant device is a board of its own running this image. The measuring range is a
//! build option: `cargo firmware --bin wv58mr --features turns-256` (default 12-bit multiturn,
//! 4096 turns).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::{table_of, Wv58mr};
use panic_probe as _;

#[cfg(any(
    all(feature = "turns-256", feature = "turns-16"),
    all(feature = "turns-256", feature = "singleturn"),
    all(feature = "turns-16", feature = "singleturn"),
))]
compile_error!("choose at most one of the features turns-256, turns-16, singleturn");

/// The measuring range this image is built for.
const TURNS: Turns = if cfg!(feature = "singleturn") {
    Turns::Single
} else if cfg!(feature = "turns-16") {
    Turns::Multi4
} else if cfg!(feature = "turns-256") {
    Turns::Multi8
} else {
    Turns::Multi12
};

/// The identity this device's parameter images carry, computed when the image is built.
const IDENTITY: u32 = od_core::storage::identity(table_of(TURNS));

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    firmware::boot_time::start();
    let board = boards::wv58mr::take(TURNS);
    let device = Wv58mr::new(TURNS);
    firmware::run::drive(board.mcu, IDENTITY, |params, uid| firmware::run::boot_j1939(device, params, uid), board.io)
        .await
}
