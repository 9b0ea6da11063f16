//! AP10T set point display (CANopen, CiA 301; no LSS): two rows of six digits on the HT1621
//! LCD, two bi-colour LEDs, four keys. Factory setting Auto baud: the controller listens silent
//! at each candidate rate until a frame arrives (D-AP-20).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use od_core::devices::ap10t::{table::TABLE, Ap10t};
use panic_probe as _;

/// The identity this device's parameter images carry, computed when the image is built.
const IDENTITY: u32 = od_core::storage::identity(TABLE);

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    firmware::boot_time::start();
    let board = boards::ap10t::take();
    firmware::run::run(Ap10t::new(), IDENTITY, board.mcu, board.io).await
}
