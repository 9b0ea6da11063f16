//! The bxCAN error state, as the firmware reads it from CAN_ESR, turned into the
//! [`BusEvent`]s the core wants (5000h counters, 1002h, EMCY 8120h / 8140h, LED states).
//!
//! The shell reads the register after every interrupt and on every loop turn and hands the
//! snapshot to [`ErrorTracker::update`]; the tracker reports each change once. Bus-off
//! recovery itself is the controller's (automatic bus-off management, ABOM: 128 × 11
//! recessive bits), so the tracker sees `BusOff` and later `BusOffRecovered`.

use heapless::Vec;
use od_core::node::{BusEvent, CanError};

/// The CAN_ESR fields the tracker uses.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Esr {
    /// Transmit error counter (TEC).
    pub tec: u8,
    /// Receive error counter (REC).
    pub rec: u8,
    /// Bus-off flag (BOFF).
    pub boff: bool,
    /// Error-passive flag (EPVF).
    pub epvf: bool,
    /// Last error code (LEC, 0..=7); the shell writes 7 after reading it, so a new error
    /// shows up as a value 1..=6.
    pub lec: u8,
}

impl Esr {
    /// Decodes the register value.
    pub const fn from_bits(esr: u32) -> Esr {
        Esr {
            tec: (esr >> 16) as u8,
            rec: (esr >> 24) as u8,
            boff: esr & (1 << 2) != 0,
            epvf: esr & (1 << 1) != 0,
            lec: ((esr >> 4) & 7) as u8,
        }
    }
}

/// The controller's fault confinement state.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum ErrorState {
    /// Both counters below 128.
    #[default]
    Active,
    /// A counter at or above 128.
    Passive,
    /// TEC above 255: off the bus until recovery.
    BusOff,
}

/// The last error code as the core's [`CanError`] (LEC 0 "no error" and 7 "set by
/// software" are none).
pub const fn protocol_error(lec: u8) -> Option<CanError> {
    match lec {
        1 => Some(CanError::Stuff),
        2 => Some(CanError::Form),
        3 => Some(CanError::Acknowledge),
        4 | 5 => Some(CanError::Bit),
        6 => Some(CanError::Crc),
        _ => None,
    }
}

/// Tracks the error state between snapshots.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct ErrorTracker {
    state: ErrorState,
    counters: (u8, u8),
}

/// The events one snapshot can produce.
pub type Events = Vec<BusEvent, 4>;

impl ErrorTracker {
    /// The state of the last snapshot.
    pub fn state(&self) -> ErrorState {
        self.state
    }

    /// Takes a snapshot; returns what changed since the previous one, in the order the core
    /// should see it: the protocol error, the counters, then the state change ([`Self::each`],
    /// collected).
    pub fn update(&mut self, esr: Esr) -> Events {
        let mut ev = Events::new();
        self.each(esr, |e| {
            let _ = ev.push(e);
        });
        ev
    }

    /// Takes a snapshot and hands `event` what changed since the previous one, in the order of
    /// [`Self::update`] (the firmware passes each straight to the node).
    pub fn each(&mut self, esr: Esr, mut event: impl FnMut(BusEvent)) {
        if let Some(e) = protocol_error(esr.lec) {
            event(BusEvent::ProtocolError(e));
        }
        if (esr.rec, esr.tec) != self.counters {
            self.counters = (esr.rec, esr.tec);
            event(BusEvent::ErrorCounters { rx: esr.rec, tx: esr.tec });
        }
        let state = if esr.boff {
            ErrorState::BusOff
        } else if esr.epvf {
            ErrorState::Passive
        } else {
            ErrorState::Active
        };
        let change = match (self.state, state) {
            (a, b) if a == b => None,
            (_, ErrorState::BusOff) => Some(BusEvent::BusOff),
            (ErrorState::BusOff, _) => Some(BusEvent::BusOffRecovered),
            (_, ErrorState::Passive) => Some(BusEvent::ErrorPassive),
            (_, ErrorState::Active) => Some(BusEvent::ErrorActive),
        };
        if let Some(c) = change {
            event(c);
            // Recovered straight into error passive (REC still high): say so too.
            if c == BusEvent::BusOffRecovered && state == ErrorState::Passive {
                event(BusEvent::ErrorPassive);
            }
        }
        self.state = state;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn esr(tec: u8, rec: u8, epvf: bool, boff: bool) -> Esr {
        Esr { tec, rec, epvf, boff, lec: 7 }
    }

    #[test]
    fn decodes_the_register() {
        let e = Esr::from_bits(0x0590_0036 | (1 << 1));
        assert_eq!(e, Esr { tec: 0x90, rec: 0x05, boff: true, epvf: true, lec: 3 });
    }

    #[test]
    fn passive_bus_off_and_recovery() {
        let mut t = ErrorTracker::default();
        assert!(t.update(esr(0, 0, false, false)).is_empty());
        assert_eq!(t.update(esr(8, 0, false, false)).as_slice(), &[BusEvent::ErrorCounters { rx: 0, tx: 8 }]);
        assert_eq!(
            t.update(esr(128, 0, true, false)).as_slice(),
            &[BusEvent::ErrorCounters { rx: 0, tx: 128 }, BusEvent::ErrorPassive]
        );
        assert!(t.update(esr(128, 0, true, false)).is_empty(), "reported once");
        assert_eq!(
            t.update(esr(255, 0, true, true)).as_slice(),
            &[BusEvent::ErrorCounters { rx: 0, tx: 255 }, BusEvent::BusOff]
        );
        assert_eq!(t.state(), ErrorState::BusOff);
        assert_eq!(
            t.update(esr(0, 0, false, false)).as_slice(),
            &[BusEvent::ErrorCounters { rx: 0, tx: 0 }, BusEvent::BusOffRecovered]
        );
        assert_eq!(t.state(), ErrorState::Active);
    }

    #[test]
    fn back_to_active_and_recovery_into_passive() {
        let mut t = ErrorTracker::default();
        t.update(esr(0, 130, true, false));
        assert_eq!(t.update(esr(0, 100, false, false)).last(), Some(&BusEvent::ErrorActive));
        t.update(esr(255, 0, true, true));
        let ev = t.update(esr(0, 140, true, false));
        assert_eq!(&ev[1..], &[BusEvent::BusOffRecovered, BusEvent::ErrorPassive]);
    }

    #[test]
    fn protocol_errors() {
        let mut t = ErrorTracker::default();
        let ev = t.update(Esr { lec: 3, ..Esr::default() });
        assert_eq!(ev.as_slice(), &[BusEvent::ProtocolError(CanError::Acknowledge)]);
        assert!(t.update(Esr { lec: 7, ..Esr::default() }).is_empty());
        assert!(t.update(Esr { lec: 0, ..Esr::default() }).is_empty());
        for (lec, e) in
            [(1, CanError::Stuff), (2, CanError::Form), (4, CanError::Bit), (5, CanError::Bit), (6, CanError::Crc)]
        {
            assert_eq!(protocol_error(lec), Some(e));
        }
    }
}
