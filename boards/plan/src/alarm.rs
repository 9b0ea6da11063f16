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
//! FFFFh is doubtful too: the model's counter wraps after 65535 ticks (its limit is ARR = FFFFh
//! and a limit is reached when the value gets there), so it never reads FFFFh, and a compare at
//! FFFFh fires only by reaching its limit in the same clock update as the wrap.
//!
//! [`wake_tick`] moves a wake-up time whose low 16 bits are FFFFh or 0 to the next tick whose
//! low 16 bits are 1, at most 2 ticks later. On the STM32 that delays two wake-ups in 65536 by
//! 1 or 2 µs, far inside every tolerance of the protocols (the shortest is the 1 ms sample
//! period); in Renode it is what keeps the boards running. Every timer the firmware awaits goes
//! through it (`firmware::wake_at`), so the driver's queue never holds a time the model may not
//! fire.

/// The compare value Renode's STM32 timer model never fires for.
pub const LOST_COMPARE: u16 = 0;

/// The compare value Renode's model fires for only together with the counter's wrap.
pub const WRAP_COMPARE: u16 = 0xFFFF;

/// The earliest tick at or after `tick` whose low 16 bits (what the time driver writes into
/// the compare register) are neither [`LOST_COMPARE`] nor [`WRAP_COMPARE`]: `tick` itself, or
/// one or two ticks later.
pub const fn wake_tick(tick: u64) -> u64 {
    match tick as u16 {
        WRAP_COMPARE => tick + 2,
        LOST_COMPARE => tick + 1,
        _ => tick,
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
    fn only_the_doubtful_compare_values_move() {
        for tick in [1u64, 2, 999, 0x7FFF, 0x8000, 0xFFFE, 0x1_0001, 0x1234_5678] {
            assert_eq!(wake_tick(tick), tick, "{tick:#x}");
        }
        for k in [0u64, 1, 2, 125, 0xFFFF_FFFF] {
            let tick = k << 16;
            assert_eq!(wake_tick(tick), tick + 1, "{tick:#x}");
            assert_eq!(compare(wake_tick(tick)), 1);
            if k > 0 {
                assert_eq!(wake_tick(tick - 1), tick + 1, "{:#x}", tick - 1);
            }
        }
    }

    /// The run loop's 1 ms sample grid, from any start, over ten minutes: without the shift
    /// some of its wake-ups would be programmed as compare value 0 (the grid meets a multiple
    /// of 65536 µs every 8.192 s when it starts on a multiple of 8 µs); with it none is (nor
    /// FFFFh), and none is more than 2 µs late.
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
                assert!(![LOST_COMPARE, WRAP_COMPARE].contains(&compare(w)), "start {start}, tick {t}");
                assert!(w >= t && w - t <= 2);
                t += 1_000;
            }
        }
        assert!(lost_without > 0, "the grid does meet compare value 0 without the shift");
    }
}
