//! The Embassy shell around `od-core`: it moves frames, time, sensor samples and parameter
//! images between the STM32F103's peripherals and a [`od_core::Node`], and decides nothing of
//! the protocol itself.
//!
//! - [`can`]: the bxCAN at the node's bit rate, its acceptance filters, the receive queue and
//!   the priority-ordered transmit queue, the controller's error state;
//! - [`params`]: the parameter pages `memory.x` reserves, through the blocking flash driver;
//! - [`boot_time`]: the cycle count from reset to the first frame, logged once;
//! - `mem`: the image's `memcpy`, `memset` and friends, small Thumb-2 loops (D-ARCH-7);
//! - [`run`]: boot and the one loop that waits for the next frame, the core's next deadline or
//!   the next sample, whichever comes first.
//!
//! A binary (`src/bin/<device>.rs`) takes its board, builds its device and calls [`run::boot`]
//! and [`run::run`].
#![no_std]
#![deny(missing_docs)]

pub mod boot_time;
pub mod can;
mod mem;
pub mod params;
pub mod run;

/// The time since reset as the core takes it (Embassy's TIM2 driver, 1 µs tick).
pub fn now() -> od_core::Instant {
    od_core::Instant::from_micros(embassy_time::Instant::now().as_micros())
}

/// When to wake for something due at `t`: `t`, or 1 or 2 µs later if the time driver would
/// program `t` as a compare value Renode's timer model may not fire for (0, FFFFh;
/// [`board_plan::alarm`]). Every timer the firmware awaits is set through it.
pub fn wake_at(t: embassy_time::Instant) -> embassy_time::Instant {
    embassy_time::Instant::from_ticks(board_plan::alarm::wake_tick(t.as_ticks()))
}
