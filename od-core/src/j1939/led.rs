//! The three LEDs of one WV58MR channel (manual §3, Tables 1-4; D-J1939-8) as a pure function
//! of the channel's state; [`crate::led::Leds::lit`] and [`crate::led::Leds::next_change`] turn
//! them into pin levels in virtual time.
//!
//! - green: blinking while address claiming is active (and when it failed), on once the address
//!   is claimed, off before the start;
//! - red: on from the CAN warning limit (an error counter at 96 or more) and at bus-off, off
//!   without error;
//! - yellow: blinking while the maximum speed is exceeded, off in the valid speed range.
//!
//! "Blinking" is the 2.5 Hz [`LedState::Flashing`] pattern (200 ms on, 200 ms off) on the
//! common time base, so green and yellow blink in step.

use crate::j1939::claim::State;
use crate::led::{LedState, Leds};

/// What the LEDs of one channel show.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LedInputs {
    /// The address claimer's state.
    pub claim: State,
    /// The CAN controller is bus-off.
    pub bus_off: bool,
    /// An error counter of the CAN controller has reached the warning limit.
    pub warning_limit: bool,
    /// The maximum speed (or a limit speed) is exceeded.
    pub over_speed: bool,
}

/// The green LED for the claimer in `claim` (manual Table 3).
pub const fn green(claim: State) -> LedState {
    match claim {
        State::Off => LedState::Off,
        State::Claimed { .. } => LedState::On,
        State::Starting { .. } | State::Claiming { .. } | State::CannotClaim => LedState::Flashing,
    }
}

/// The LED states for `inputs`.
pub const fn leds(inputs: &LedInputs) -> Leds {
    let green = green(inputs.claim);
    let red = if inputs.bus_off || inputs.warning_limit { LedState::On } else { LedState::Off };
    let yellow = if inputs.over_speed { LedState::Flashing } else { LedState::Off };
    Leds { green, red, yellow }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::led::Lit;
    use crate::time::Instant;
    use crate::wire::j1939::Address;

    fn quiet(claim: State) -> LedInputs {
        LedInputs { claim, bus_off: false, warning_limit: false, over_speed: false }
    }

    const CLAIMED: State = State::Claimed { address: Address(0xEF) };

    #[test]
    fn green_follows_the_claim() {
        let claiming = State::Claiming { address: Address(0xEF), since: Instant::ZERO };
        assert_eq!(leds(&quiet(State::Off)).green, LedState::Off);
        assert_eq!(leds(&quiet(claiming)).green, LedState::Flashing);
        assert_eq!(leds(&quiet(State::CannotClaim)).green, LedState::Flashing);
        assert_eq!(leds(&quiet(CLAIMED)), Leds { green: LedState::On, red: LedState::Off, yellow: LedState::Off });
        // Blinking in virtual time: 200 ms on, 200 ms off.
        let l = leds(&quiet(claiming));
        let at = |ms| l.lit(Instant::from_millis(ms)).green;
        assert!(at(0) && at(199) && !at(200) && !at(399) && at(400));
        assert_eq!(l.next_change(Instant::from_millis(10)), Some(Instant::from_millis(200)));
        assert_eq!(leds(&quiet(CLAIMED)).next_change(Instant::from_millis(10)), None);
    }

    #[test]
    fn red_on_from_the_warning_limit_and_at_bus_off() {
        for (warning_limit, bus_off, red) in [
            (false, false, LedState::Off),
            (true, false, LedState::On),
            (false, true, LedState::On),
            (true, true, LedState::On),
        ] {
            let l = leds(&LedInputs { claim: CLAIMED, bus_off, warning_limit, over_speed: false });
            assert_eq!(l.red, red);
            assert_eq!(l.green, LedState::On);
        }
    }

    #[test]
    fn yellow_blinks_over_speed_in_step_with_a_blinking_green() {
        let l = leds(&LedInputs {
            claim: State::Claiming { address: Address(0x80), since: Instant::ZERO },
            bus_off: false,
            warning_limit: false,
            over_speed: true,
        });
        assert_eq!(l.yellow, LedState::Flashing);
        for ms in (0..2000).step_by(50) {
            let lit: Lit = l.lit(Instant::from_millis(ms));
            assert_eq!(lit.green, lit.yellow, "{ms} ms");
        }
        assert!(!leds(&quiet(CLAIMED)).lit(Instant::from_millis(100)).yellow);
    }
}
