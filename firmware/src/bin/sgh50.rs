//! SGH50 draw-wire encoder, single or one channel of the redundant version (CANopen, CiA 301 +
//! CiA 406, LSS): the channel comes from the board's straps.
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use od_core::devices::sgh50::{self, Sgh50};
use panic_probe as _;

/// The identity this device's parameter images carry, computed when the image is built.
const IDENTITY: u32 = od_core::storage::identity(sgh50::TABLE);

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    firmware::boot_time::start();
    let board = boards::sgh50::take();
    firmware::run::run(Sgh50::new(board.variant), IDENTITY, board.mcu, board.io).await
}
