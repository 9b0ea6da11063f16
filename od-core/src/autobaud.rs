//! Automatic bit-rate detection ("Auto baud", the AP10T's factory setting, manual 4.6.1): the
//! node listens without transmitting at one candidate rate after another, each for a dwell
//! time, until a frame arrives without error; it then takes that rate and boots up.
//!
//! How the core expresses it (D-AP-20): the scan is a state of the node, before the boot-up.
//! The node asks the shell for each candidate with `Output::SetBitrate` and reports
//! `Node::listen_only()` true meanwhile, so the shell runs its controller silent (no ACK, no
//! error frame: the firmware's bxCAN silent mode). The shell passes only frames its controller
//! received without error at that rate, which a controller at another rate cannot: the
//! first frame the node gets proves the rate. The virtual bus models exactly that, since a node
//! receives only the frames sent at the rate it runs at.

use crate::bitrate::Bitrate;
use crate::time::Instant;

/// How long each candidate is listened to, in milliseconds (AP10T A31: not stated). Any one
/// second of a bus with a heartbeat or SYNC of at most one second holds a frame.
pub const DWELL_MS: u64 = 1000;

/// A running scan over `rates`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Scan {
    rates: &'static [Bitrate],
    index: usize,
    /// When the current candidate's dwell time ends (`None` before the first poll).
    until: Option<Instant>,
}

impl Scan {
    /// A scan that starts with `rates[0]`; `None` for an empty list.
    pub fn new(rates: &'static [Bitrate]) -> Option<Scan> {
        (!rates.is_empty()).then_some(Scan { rates, index: 0, until: None })
    }

    /// The rate listened to now.
    pub fn rate(&self) -> Bitrate {
        self.rates[self.index % self.rates.len()]
    }

    /// Runs the dwell timer; returns the next candidate when it is time to switch.
    pub fn poll(&mut self, now: Instant) -> Option<Bitrate> {
        if self.until.is_some_and(|t| now < t) {
            return None;
        }
        let first = self.until.is_none();
        self.until = Some(now.add_millis(DWELL_MS));
        if first {
            return None;
        }
        self.index = (self.index + 1) % self.rates.len();
        Some(self.rate())
    }

    /// When [`Scan::poll`] must next run.
    pub fn next_deadline(&self) -> Instant {
        self.until.unwrap_or(Instant::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static RATES: [Bitrate; 3] = [Bitrate::K125, Bitrate::K250, Bitrate::K500];

    #[test]
    fn each_rate_for_the_dwell_time_round_and_round() {
        assert!(Scan::new(&[]).is_none());
        let mut s = Scan::new(&RATES).unwrap();
        assert_eq!((s.rate(), s.next_deadline()), (Bitrate::K125, Instant::ZERO));
        let t0 = Instant::from_millis(5);
        assert_eq!(s.poll(t0), None);
        assert_eq!(s.next_deadline(), t0.add_millis(DWELL_MS));
        assert_eq!(s.poll(t0.add_millis(DWELL_MS - 1)), None);
        assert_eq!(s.poll(t0.add_millis(DWELL_MS)), Some(Bitrate::K250));
        assert_eq!(s.poll(t0.add_millis(2 * DWELL_MS)), Some(Bitrate::K500));
        assert_eq!(s.poll(t0.add_millis(3 * DWELL_MS)), Some(Bitrate::K125));
        assert_eq!(s.rate(), Bitrate::K125);
    }
}
