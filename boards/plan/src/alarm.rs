//! When the firmware asks to be woken: a time Embassy's TIM2 time driver can program as a compare
//! value that both the STM32 and Renode's timer model raise an interrupt for.
//!
//! Embassy's 16-bit time driver (embassy-stm32 `time_driver/gp16.rs`) counts one tick per
//! microsecond (`tick-hz-1_000_000`) and wakes the executor for the earliest queued timer by
//! writing that time's low 16 bits into TIM2_CCR2 and waiting for the compare interrupt. The
//! STM32 raises it for every value, 0 included (the counter passing from FFFFh to 0). Renode's
//! `Timers.STM32_Timer` never does for 0: a compare channel is a one-shot timer counting from
//! the counter's value up to CCR, armed only while the counter is below CCR, and a write of 0
//! disarms it (renode issue 1007). The alarm is lost, nothing else wakes an idle loop, and the
//! watchdog resets the board. The firmware's 1 ms sample grid meets a multiple of 65536 µs
//! every 8.192 s (1000 and 65536 share the factor 8); heartbeat, LED and protocol deadlines
//! meet one at random, once in 65536.
//!
//! [`wake_tick`] moves a wake-up time whose low 16 bits are 0 one tick later. On the STM32 that
//! delays one wake-up in 65536 by 1 µs, far inside every tolerance of the protocols (the
//! shortest is the 1 ms sample period); in Renode it is what keeps the boards running. Every
//! timer the firmware awaits goes through it (`firmware::wake_at`), so the driver's queue never
//! holds a time the model cannot fire.

/// The compare value Renode's STM32 timer model never fires for.
pub const LOST_COMPARE: u16 = 0;

/// The earliest tick at or after `tick` whose low 16 bits (what the time driver writes into
/// the compare register) are not [`LOST_COMPARE`]: `tick` itself, or one tick later.
pub const fn wake_tick(tick: u64) -> u64 {
    if tick as u16 == LOST_COMPARE {
        tick + 1
    } else {
        tick
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compare value the driver programs for a wake-up at `tick`.
    fn compare(tick: u64) -> u16 {
        tick as u16
    }

    #[test]
    fn only_the_lost_compare_value_moves() {
        for tick in [1u64, 2, 999, 0x7FFF, 0x8000, 0xFFFF, 0x1_0001, 0x1234_5678] {
            assert_eq!(wake_tick(tick), tick, "{tick:#x}");
        }
        for k in [0u64, 1, 2, 125, 0xFFFF_FFFF] {
            let tick = k << 16;
            assert_eq!(wake_tick(tick), tick + 1, "{tick:#x}");
            assert_ne!(compare(wake_tick(tick)), LOST_COMPARE);
        }
    }

    /// The run loop's 1 ms sample grid, from any start, over ten minutes: without the shift
    /// some of its wake-ups would be programmed as compare value 0 (the grid meets a multiple
    /// of 65536 µs every 8.192 s when it starts on a multiple of 8 µs); with it none is, and
    /// none is more than 1 µs late.
    #[test]
    fn ten_minutes_of_the_sample_grid_never_program_compare_zero() {
        let mut lost_without = 0;
        for start in 0..16u64 {
            let mut t = start;
            while t < 600_000_000 {
                if compare(t) == LOST_COMPARE {
                    lost_without += 1;
                }
                let w = wake_tick(t);
                assert_ne!(compare(w), LOST_COMPARE, "start {start}, tick {t}");
                assert!(w >= t && w - t <= 1);
                t += 1_000;
            }
        }
        assert!(lost_without > 0, "the grid does meet compare value 0 without the shift");
    }
}
