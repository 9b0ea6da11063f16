//! The WV5800M's three LEDs as a pure function of the node's state and of time.
//!
//! - green "CAN Run" and red "CAN Err" follow CiA 303-3 as the manual's Tables 2-5 print them:
//!   green flashing in PRE-OPERATIONAL, on in OPERATIONAL, single flash in STOPPED; red off
//!   without error, single flash at the CAN warning limit, double flash after a guard event, on
//!   at bus-off; both flickering alternately in the LSS configuration state (the LSS waiting
//!   state is not shown);
//! - yellow: on while the maximum speed is exceeded (Table 1).
//!
//! [`Leds::from_inputs`] picks each LED's [`LedState`]; [`Leds::lit`] says which LEDs are lit
//! at a given instant, the patterns running on the time since power-on (`Instant::ZERO`) so the
//! green and red LEDs stay in step as CiA 303-3 asks; [`Leds::next_change`] is when the shell
//! must next update them. The firmware's LED task only drives pins.

use crate::nmt::NmtState;
use crate::time::Instant;

/// What an LED shows (CiA 303-3, manual Table 2).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum LedState {
    /// Permanently off.
    Off,
    /// Permanently on.
    On,
    /// 10 Hz: 50 ms on, 50 ms off; the green and red LEDs alternately.
    Flickering,
    /// 2.5 Hz: 200 ms on, 200 ms off.
    Flashing,
    /// 200 ms on, 1000 ms off.
    SingleFlash,
    /// 200 ms on, 200 ms off, 200 ms on, 1000 ms off.
    DoubleFlash,
}

/// The length of a pattern's slot: every CiA 303-3 pattern switches on multiples of 50 ms.
const SLOT_US: u32 = 50_000;

/// (period in slots, lit slots) of a blinking pattern: bit `k` of the mask set when the LED is
/// lit in slot `k` (from `k` × 50 ms to `k + 1` × 50 ms into the period). The longest period,
/// the double flash's 1600 ms, is 32 slots. Steady states have no slots.
const fn pattern(state: LedState) -> (u32, u32) {
    match state {
        LedState::Off | LedState::On => (0, 0),
        // 50 ms on, 50 ms off.
        LedState::Flickering => (2, 0b1),
        // 200 ms on, 200 ms off.
        LedState::Flashing => (8, 0xF),
        // 200 ms on, 1000 ms off.
        LedState::SingleFlash => (24, 0xF),
        // 200 ms on, 200 ms off, 200 ms on, 1000 ms off.
        LedState::DoubleFlash => (32, 0xF0F),
    }
}

/// Slots of the common cycle, 4.8 s: a multiple of every pattern's period (2, 8, 24 and 32
/// slots), so a pattern's slot is the cycle's slot modulo its period.
const CYCLE_SLOTS: u32 = 96;

/// The slot of the common cycle `now` falls in and the microseconds `now` lies into it: one
/// remainder for every LED.
fn clock(now: Instant) -> (u32, u32) {
    let phase = now.phase(CYCLE_SLOTS * SLOT_US);
    (phase / SLOT_US, phase % SLOT_US)
}

impl LedState {
    /// The pattern's period in slots (1 for a steady state), its lit slots (all or none for
    /// a steady state) and its slot in the common cycle's slot `cycle`; the antiphase LED (the
    /// red one, when flickering) one slot, half a flicker, later.
    fn slot(self, cycle: u32, antiphase: bool) -> (u32, u32, u32) {
        let (slots, mask) = match pattern(self) {
            (0, _) => (1, (self == LedState::On) as u32),
            p => p,
        };
        let shift = (antiphase && self == LedState::Flickering) as u32;
        (slots, mask, (cycle + shift) % slots)
    }

    /// Is the LED lit in the common cycle's slot `cycle`?
    fn lit_in(self, cycle: u32, antiphase: bool) -> bool {
        let (_, mask, slot) = self.slot(cycle, antiphase);
        mask >> slot & 1 != 0
    }

    /// In how many slot boundaries from the common cycle's slot `cycle` the LED changes
    /// (`u32::MAX` when it never does).
    fn slots_to_change(self, cycle: u32, antiphase: bool) -> u32 {
        let (slots, mask, slot) = self.slot(cycle, antiphase);
        let lit = mask >> slot & 1;
        // Every blinking pattern has lit and dark slots: it changes within one period.
        let mut k = 1;
        while k <= slots {
            if mask >> ((slot + k) % slots) & 1 != lit {
                return k;
            }
            k += 1;
        }
        u32::MAX
    }

    /// Is the LED lit at `now`? `antiphase`: this LED is the second of an alternating pair
    /// (the red one), which matters for [`LedState::Flickering`] only.
    pub fn lit(self, now: Instant, antiphase: bool) -> bool {
        self.lit_in(clock(now).0, antiphase)
    }

    /// When the LED next turns on or off after `now` (`None` when it never does).
    pub fn next_change(self, now: Instant, antiphase: bool) -> Option<Instant> {
        let (cycle, into) = clock(now);
        after(now, into, self.slots_to_change(cycle, antiphase))
    }
}

/// `k` slot boundaries after `now`, which lies `into` µs into its slot (`None` for
/// `u32::MAX`, never).
fn after(now: Instant, into: u32, k: u32) -> Option<Instant> {
    (k != u32::MAX).then(|| Instant::from_micros(now.as_micros() - into as u64 + k as u64 * SLOT_US as u64))
}

/// The conditions the LEDs show.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LedInputs {
    /// NMT state.
    pub nmt: NmtState,
    /// The LSS slave is in the configuration state.
    pub lss_configuration: bool,
    /// The CAN controller is bus-off.
    pub bus_off: bool,
    /// An error counter of the CAN controller has reached the warning limit (96).
    pub warning_limit: bool,
    /// A life guarding event happened and no guarding RTR came since.
    pub guard_event: bool,
    /// The maximum speed is exceeded.
    pub over_speed: bool,
}

/// The CAN controller warning limit of the error counters (CiA 303-3, ISO 11898-1 "error
/// warning").
pub const WARNING_LIMIT: u8 = 96;

/// What the three LEDs show.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Leds {
    /// CAN Run LED.
    pub green: LedState,
    /// CAN Err LED.
    pub red: LedState,
    /// Device status LED.
    pub yellow: LedState,
}

/// Which LEDs are lit at one instant.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Lit {
    /// Green lit.
    pub green: bool,
    /// Red lit.
    pub red: bool,
    /// Yellow lit.
    pub yellow: bool,
}

impl Leds {
    /// The LED states for `inputs`. In the LSS configuration state green and red flicker
    /// alternately whatever else holds; otherwise red shows the most severe CAN error (bus-off,
    /// then guard event, then warning limit), and green the NMT state (off while
    /// initialising).
    pub const fn from_inputs(inputs: &LedInputs) -> Leds {
        let yellow = if inputs.over_speed { LedState::On } else { LedState::Off };
        if inputs.lss_configuration {
            return Leds { green: LedState::Flickering, red: LedState::Flickering, yellow };
        }
        let green = match inputs.nmt {
            NmtState::Initialising => LedState::Off,
            NmtState::PreOperational => LedState::Flashing,
            NmtState::Operational => LedState::On,
            NmtState::Stopped => LedState::SingleFlash,
        };
        let red = if inputs.bus_off {
            LedState::On
        } else if inputs.guard_event {
            LedState::DoubleFlash
        } else if inputs.warning_limit {
            LedState::SingleFlash
        } else {
            LedState::Off
        };
        Leds { green, red, yellow }
    }

    /// Which LEDs are lit at `now`.
    pub fn lit(&self, now: Instant) -> Lit {
        let (cycle, _) = clock(now);
        Lit {
            green: self.green.lit_in(cycle, false),
            red: self.red.lit_in(cycle, true),
            yellow: self.yellow.lit_in(cycle, false),
        }
    }

    /// When any LED next changes after `now` (`None`: all steady).
    pub fn next_change(&self, now: Instant) -> Option<Instant> {
        let (cycle, into) = clock(now);
        let k = self.green.slots_to_change(cycle, false);
        let k = k.min(self.red.slots_to_change(cycle, true));
        after(now, into, k.min(self.yellow.slots_to_change(cycle, false)))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec;
    use std::vec::Vec;

    fn inputs(nmt: NmtState) -> LedInputs {
        LedInputs {
            nmt,
            lss_configuration: false,
            bus_off: false,
            warning_limit: false,
            guard_event: false,
            over_speed: false,
        }
    }

    /// The LED's on/off trace over `ms` milliseconds, sampled each millisecond, as runs of
    /// (lit, length in ms).
    fn trace(state: LedState, antiphase: bool, from_ms: u64, ms: u64) -> Vec<(bool, u64)> {
        let mut runs: Vec<(bool, u64)> = Vec::new();
        for t in from_ms..from_ms + ms {
            let on = state.lit(Instant::from_millis(t), antiphase);
            match runs.last_mut() {
                Some((l, n)) if *l == on => *n += 1,
                _ => runs.push((on, 1)),
            }
        }
        runs
    }

    #[test]
    fn nmt_states_on_the_green_led() {
        assert_eq!(Leds::from_inputs(&inputs(NmtState::PreOperational)).green, LedState::Flashing);
        assert_eq!(Leds::from_inputs(&inputs(NmtState::Operational)).green, LedState::On);
        assert_eq!(Leds::from_inputs(&inputs(NmtState::Stopped)).green, LedState::SingleFlash);
        assert_eq!(Leds::from_inputs(&inputs(NmtState::Initialising)).green, LedState::Off);
        assert_eq!(Leds::from_inputs(&inputs(NmtState::Operational)).red, LedState::Off);
    }

    #[test]
    fn blink_timing_in_virtual_time() {
        // Flashing: 200 ms on, 200 ms off.
        assert_eq!(
            trace(LedState::Flashing, false, 0, 800),
            vec![(true, 200), (false, 200), (true, 200), (false, 200)]
        );
        // Single flash: 200 ms on, 1000 ms off.
        assert_eq!(
            trace(LedState::SingleFlash, false, 0, 2400),
            vec![(true, 200), (false, 1000), (true, 200), (false, 1000)]
        );
        // Double flash: 200 on, 200 off, 200 on, 1000 off.
        assert_eq!(
            trace(LedState::DoubleFlash, false, 0, 1600),
            vec![(true, 200), (false, 200), (true, 200), (false, 1000)]
        );
        // Flickering: 50 ms on/off, the red LED in antiphase.
        assert_eq!(trace(LedState::Flickering, false, 0, 200), vec![(true, 50), (false, 50), (true, 50), (false, 50)]);
        assert_eq!(trace(LedState::Flickering, true, 0, 200), vec![(false, 50), (true, 50), (false, 50), (true, 50)]);
        for t in 0..1000 {
            let now = Instant::from_millis(t);
            let lit = Leds::from_inputs(&LedInputs { lss_configuration: true, ..inputs(NmtState::Stopped) }).lit(now);
            assert_ne!(lit.green, lit.red, "alternate at {t} ms");
        }
        assert_eq!(trace(LedState::On, false, 0, 100), vec![(true, 100)]);
        assert_eq!(trace(LedState::Off, true, 0, 100), vec![(false, 100)]);
    }

    #[test]
    fn red_led_shows_the_most_severe_can_error() {
        let base = inputs(NmtState::Operational);
        let red = |i: LedInputs| Leds::from_inputs(&i).red;
        assert_eq!(red(LedInputs { warning_limit: true, ..base }), LedState::SingleFlash);
        assert_eq!(red(LedInputs { warning_limit: true, guard_event: true, ..base }), LedState::DoubleFlash);
        assert_eq!(red(LedInputs { bus_off: true, guard_event: true, warning_limit: true, ..base }), LedState::On);
        // LSS configuration overrides both CAN LEDs; the yellow LED shows over-speed regardless.
        let l = Leds::from_inputs(&LedInputs { lss_configuration: true, bus_off: true, over_speed: true, ..base });
        assert_eq!((l.green, l.red, l.yellow), (LedState::Flickering, LedState::Flickering, LedState::On));
        assert_eq!(Leds::from_inputs(&base).yellow, LedState::Off);
    }

    /// The patterns as on-intervals in milliseconds within their period, as the manual's Table 2
    /// prints them, and the LED state at `now` and its next edge computed from them: the
    /// reference the slot masks are checked against.
    fn reference(state: LedState, now: Instant, antiphase: bool) -> (bool, Option<Instant>) {
        let (period, on): (u64, &[(u64, u64)]) = match state {
            LedState::Off => return (false, None),
            LedState::On => return (true, None),
            LedState::Flickering => (100, &[(0, 50)]),
            LedState::Flashing => (400, &[(0, 200)]),
            LedState::SingleFlash => (1200, &[(0, 200)]),
            LedState::DoubleFlash => (1600, &[(0, 200), (400, 600)]),
        };
        let shift = if antiphase && state == LedState::Flickering { 50_000 } else { 0 };
        let t = now.as_micros() + shift;
        let phase = t % (period * 1000);
        let lit = on.iter().any(|&(a, b)| phase >= a * 1000 && phase < b * 1000);
        let start = t - phase;
        let mut next = u64::MAX;
        for base in [start, start + period * 1000] {
            for &(a, b) in on {
                for edge in [base + a * 1000, base + b * 1000] {
                    if edge > t && edge < next {
                        next = edge;
                    }
                }
            }
        }
        (lit, Some(Instant::from_micros(next - shift)))
    }

    #[test]
    fn slot_masks_follow_the_printed_patterns() {
        let states = [
            LedState::Off,
            LedState::On,
            LedState::Flickering,
            LedState::Flashing,
            LedState::SingleFlash,
            LedState::DoubleFlash,
        ];
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for i in 0..200_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Every microsecond of the first 3.2 s, then instants up to 2^50 µs (35 years).
            let now = Instant::from_micros(if i < 100_000 { i * 32 } else { x >> 14 });
            for state in states {
                for anti in [false, true] {
                    let got = (state.lit(now, anti), state.next_change(now, anti));
                    assert_eq!(got, reference(state, now, anti), "{state:?} antiphase {anti} at {now:?}");
                }
            }
            // Three LEDs at once: each lit as its own reference says, the earliest edge next.
            let leds = Leds {
                green: states[(x % 6) as usize],
                red: states[(x / 6 % 6) as usize],
                yellow: states[(x / 36 % 6) as usize],
            };
            let (g, r, y) =
                (reference(leds.green, now, false), reference(leds.red, now, true), reference(leds.yellow, now, false));
            assert_eq!(leds.lit(now), Lit { green: g.0, red: r.0, yellow: y.0 }, "{leds:?} at {now:?}");
            let next = crate::time::earliest(crate::time::earliest(g.1, r.1), y.1);
            assert_eq!(leds.next_change(now), next, "{leds:?} at {now:?}");
        }
    }

    #[test]
    fn next_change_is_the_next_edge() {
        for state in [LedState::Flickering, LedState::Flashing, LedState::SingleFlash, LedState::DoubleFlash] {
            for anti in [false, true] {
                let mut t = Instant::from_millis(7);
                for _ in 0..20 {
                    let next = state.next_change(t, anti).unwrap();
                    assert!(next > t);
                    // Steady from t up to just before `next`, and it changes at `next`.
                    let before = state.lit(Instant::from_micros(next.as_micros() - 1), anti);
                    assert_eq!(state.lit(t, anti), before, "{state:?} steady until {next:?}");
                    assert_ne!(state.lit(next, anti), before, "{state:?} changes at {next:?}");
                    t = next;
                }
            }
        }
        assert_eq!(LedState::On.next_change(Instant::ZERO, false), None);
        let leds = Leds::from_inputs(&inputs(NmtState::PreOperational));
        assert_eq!(leds.next_change(Instant::from_millis(150)), Some(Instant::from_millis(200)));
        assert_eq!(Leds::from_inputs(&inputs(NmtState::Operational)).next_change(Instant::ZERO), None);
    }
}
