//! Why the MCU reset, from the RCC_CSR reset flags (RM0008 §7.3.10).

/// The reset cause, most specific first.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ResetCause {
    /// The independent watchdog expired: the main loop stopped feeding it.
    IndependentWatchdog,
    /// The window watchdog.
    WindowWatchdog,
    /// A low-power management reset.
    LowPower,
    /// Software (`SYSRESETREQ`, e.g. after a panic or a firmware update).
    Software,
    /// Power-on / power-down reset.
    PowerOn,
    /// The NRST pin.
    Pin,
    /// No flag set (a debugger reset that cleared them).
    Unknown,
}

impl ResetCause {
    /// The cause the flags of RCC_CSR record. Several flags can be set together (a power-on
    /// also sets the pin flag): the most specific wins.
    pub const fn from_csr(csr: u32) -> ResetCause {
        const LPWR: u32 = 1 << 31;
        const WWDG: u32 = 1 << 30;
        const IWDG: u32 = 1 << 29;
        const SFT: u32 = 1 << 28;
        const POR: u32 = 1 << 27;
        const PIN: u32 = 1 << 26;
        if csr & IWDG != 0 {
            ResetCause::IndependentWatchdog
        } else if csr & WWDG != 0 {
            ResetCause::WindowWatchdog
        } else if csr & LPWR != 0 {
            ResetCause::LowPower
        } else if csr & SFT != 0 {
            ResetCause::Software
        } else if csr & POR != 0 {
            ResetCause::PowerOn
        } else if csr & PIN != 0 {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }

    /// Was the reset a fault (a watchdog expiry)?
    pub const fn is_fault(self) -> bool {
        matches!(self, ResetCause::IndependentWatchdog | ResetCause::WindowWatchdog)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn most_specific_flag_wins() {
        assert_eq!(ResetCause::from_csr(0x0C00_0000), ResetCause::PowerOn);
        assert_eq!(ResetCause::from_csr(0x2400_0000), ResetCause::IndependentWatchdog);
        assert_eq!(ResetCause::from_csr(0x1400_0000), ResetCause::Software);
        assert_eq!(ResetCause::from_csr(0x0400_0000), ResetCause::Pin);
        assert_eq!(ResetCause::from_csr(0), ResetCause::Unknown);
        assert!(ResetCause::from_csr(1 << 29).is_fault());
        assert!(!ResetCause::PowerOn.is_fault());
    }
}
