//! The independent watchdog's prescaler and reload value for a timeout (RM0008 19.3): the
//! smallest prescaler (÷4 .. ÷256) whose longest timeout (4096 LSI periods of it) covers the
//! timeout, and the reload value that gives the timeout at the nominal LSI clock, as Embassy's
//! `IndependentWatchdog::new` chose them at run time; here the firmware has them as constants.

/// The nominal LSI clock of the STM32F1 (40 kHz; the real one lies between 30 and 60 kHz).
pub const LSI_HZ: u32 = 40_000;

/// The largest reload value (IWDG_RLR is 12 bits).
const MAX_RELOAD: u32 = 0xFFF;

/// The timeout in microseconds of prescaler `divider` and reload value `reload`.
const fn timeout_us(divider: u32, reload: u32) -> u32 {
    (1_000_000 * (reload + 1) as u64 / (LSI_HZ / divider) as u64) as u32
}

/// The register values for `timeout_us`: IWDG_PR (0 = ÷4 .. 6 = ÷256) and IWDG_RLR. Panics (at
/// compile time, where the firmware evaluates it) if even ÷256 cannot reach the timeout.
pub const fn registers(timeout_us: u32) -> (u8, u16) {
    let mut power = 2;
    while power <= 8 {
        let divider = 1 << power;
        if timeout_us <= timeout_us_of(divider) {
            let reload = timeout_us / divider * LSI_HZ / 1_000_000 - 1;
            return ((power - 2) as u8, reload as u16);
        }
        power += 1;
    }
    panic!("timeout beyond the independent watchdog's reach")
}

/// The longest timeout of prescaler `divider`.
const fn timeout_us_of(divider: u32) -> u32 {
    timeout_us(divider, MAX_RELOAD)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_firmware_timeout() {
        // 256 ms: ÷4 (409.6 ms at most), 2560 periods of 100 µs.
        assert_eq!(registers(256_000), (0, 2559));
        assert_eq!(timeout_us(4, 2559), 256_000);
    }

    #[test]
    fn smallest_prescaler_that_reaches() {
        assert_eq!(registers(409_600), (0, 4095));
        assert_eq!(registers(409_700).0, 1);
        assert_eq!(registers(26_214_400), (6, 4095));
        for t in [1_000, 100_000, 1_000_000, 10_000_000, 26_000_000] {
            let (pr, rl) = registers(t);
            let divider = 4 << pr;
            assert!(rl <= 0xFFF);
            // Within 0.2 % of the wanted timeout (÷128 and ÷256 do not divide 40 kHz evenly).
            let got = timeout_us(divider, rl as u32);
            assert!(got.abs_diff(t) <= t / 500, "{t}: {got}");
        }
    }
}
