//! How long the board takes from reset to its first frame (the CANopen boot-up message, the
//! J1939 address claim), in CPU cycles, logged once over defmt (issue 14: under 10 ms, 720,000
//! cycles at 72 MHz, loading the stored parameters included).
//!
//! The Cortex-M3's DWT cycle counter starts at the top of `main`, before the clocks are set up
//! (the few thousand cycles of the runtime's RAM initialisation before it are not counted), so
//! the first part runs at the 8 MHz HSI and the figure is cycles, not time. A board or a Renode
//! run shows it as `boot: first frame queued N cycles after reset`.

use core::sync::atomic::{AtomicBool, Ordering};
use cortex_m::peripheral::DWT;

static LOGGED: AtomicBool = AtomicBool::new(false);

/// Starts the cycle counter: the first thing `main` does.
pub fn start() {
    // SAFETY: only the trace enable bit of DEMCR and the counter of DWT are touched, before
    // anything else runs; nothing else in the firmware uses them.
    let mut core = unsafe { cortex_m::Peripherals::steal() };
    core.DCB.enable_trace();
    core.DWT.set_cycle_count(0);
    core.DWT.enable_cycle_counter();
}

/// A frame is about to be queued: the first one's cycle count is logged.
#[inline]
pub fn frame_queued() {
    if !LOGGED.load(Ordering::Relaxed) {
        LOGGED.store(true, Ordering::Relaxed);
        defmt::info!("boot: first frame queued {=u32} cycles after reset", DWT::cycle_count());
    }
}
