//! SGH10 / SGH10L draw-wire encoder (CANopen, CiA 301 + CiA 406, LSS).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use od_core::devices::sgh10::{self, Sgh10};
use panic_probe as _;

/// The identity this device's parameter images carry, computed when the image is built.
const IDENTITY: u32 = od_core::storage::identity(sgh10::TABLE);

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    firmware::boot_time::start();
    let board = boards::sgh10::take();
    firmware::run::run(Sgh10::new(board.variant), IDENTITY, board.mcu, board.io).await
}
