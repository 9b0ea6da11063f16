//! Address claiming per SAE J1939-81, as the WV58MR needs it (manual §5.2, §5.3; the
//! decisions D-J1939-1, -3, -4 and -8 in `docs/decisions.md`).
//!
//! - [`AddressClaimer::start`] claims the preferred address (5F0Ah.01, default EFh) with an
//!   Address Claimed message (PGN 60928, priority 6, to the global address);
//!   [`AddressClaimer::start_delayed`] does so after the CA's pseudo-random delay of 0..153 ms,
//!   so that two CAs powered up together (the two channels of a WV58MR) do not send the same
//!   identifier with different data at the same instant (D-J1939-13).
//! - A Request for Address Claimed (PGN 59904 with PGN 60928) to the global address or to our
//!   address is answered with our claim, during the contention period too.
//! - An Address Claimed message for our address from another CA is a contest: the numerically
//!   lower NAME wins. Winning, we claim our address again; losing (or meeting an equal NAME),
//!   an arbitrary-address-capable CA claims the next address in its range that no other CA has
//!   been seen claiming, and with none left (or without that capability) it sends Cannot Claim
//!   from the null address FEh and stays silent, answering only a global Request for Address
//!   Claimed with Cannot Claim after a pseudo-random delay of 0..153 ms.
//! - No other traffic leaves the CA until its claim has stood for 250 ms without being lost:
//!   [`AddressClaimer::source_address`] is `None` until then.
//!
//! The claimer is a value: frames it must send are returned from the call that causes them,
//! timed ones come from [`AddressClaimer::poll`] at [`AddressClaimer::next_deadline`]. It keeps
//! a 256-bit table of the addresses other CAs claimed, nothing else.

use crate::frame::Frame;
use crate::led::LedState;
use crate::time::Instant;
use crate::wire::j1939::{Address, AddressClaimed, Identifier, Name, Pgn, Request};

/// How long a claim must stand before the CA sends anything else (J1939-81).
pub const CONTENTION_MS: u64 = 250;

/// The step of the Cannot Claim delay: 0..=255 steps of 600 µs, 0..153 ms (J1939-81).
pub const CANNOT_CLAIM_STEP_US: u64 = 600;

/// Where the claimer stands.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum State {
    /// Not started: nothing sent, nothing answered.
    Off,
    /// Started; the first claim goes out at `at` ([`AddressClaimer::start_delayed`]).
    Starting {
        /// When the claim is due.
        at: Instant,
    },
    /// `address` claimed at `since`; the claim has not yet stood for 250 ms.
    Claiming {
        /// The address claimed.
        address: Address,
        /// When the claim was sent.
        since: Instant,
    },
    /// `address` is ours: the claim stood for 250 ms.
    Claimed {
        /// Our source address.
        address: Address,
    },
    /// No address could be claimed: Cannot Claim was sent, the CA is silent.
    CannotClaim,
}

/// The J1939-81 address-claim state machine of one controller application.
#[derive(Clone, Debug)]
pub struct AddressClaimer {
    name: Name,
    preferred: Address,
    lowest: u8,
    highest: u8,
    state: State,
    /// Addresses other CAs have claimed on this bus, one bit each.
    taken: [u32; 8],
    /// A Cannot Claim answer due at this instant.
    cannot_claim_due: Option<Instant>,
}

impl AddressClaimer {
    /// A claimer for `name` that prefers `preferred` and, losing, moves within
    /// `lowest..=highest` (the WV58MR: 80h..=EFh, the range 5F0Ah.01 accepts). Not started.
    pub const fn new(name: Name, preferred: Address, lowest: u8, highest: u8) -> AddressClaimer {
        AddressClaimer { name, preferred, lowest, highest, state: State::Off, taken: [0; 8], cannot_claim_due: None }
    }

    /// Our NAME.
    pub const fn name(&self) -> Name {
        self.name
    }

    /// The current state.
    pub const fn state(&self) -> State {
        self.state
    }

    /// The address the CA may send ordinary traffic from: `Some` only once its claim has
    /// stood for 250 ms (after the [`AddressClaimer::poll`] at that deadline).
    pub const fn source_address(&self) -> Option<Address> {
        match self.state {
            State::Claimed { address } => Some(address),
            _ => None,
        }
    }

    /// The address claimed or being claimed (`None` when off or unable to claim): the address
    /// destination-specific messages to this CA use.
    pub const fn address(&self) -> Option<Address> {
        match self.state {
            State::Claiming { address, .. } | State::Claimed { address } => Some(address),
            _ => None,
        }
    }

    /// The green LED (manual Table 3): blinking while address claiming is active or has
    /// failed, on once the address is claimed, off before the start (D-J1939-8).
    pub const fn green_led(&self) -> LedState {
        crate::j1939::led::green(self.state)
    }

    /// Has another CA been seen claiming `address`?
    pub const fn is_taken(&self, address: Address) -> bool {
        self.taken[(address.0 >> 5) as usize] & (1 << (address.0 & 31)) != 0
    }

    fn mark_taken(&mut self, address: Address) {
        self.taken[(address.0 >> 5) as usize] |= 1 << (address.0 & 31);
    }

    /// Start (power-on, or 3002h.01 "SAE initialise"): claim the preferred address now. The
    /// returned frame goes on the bus at `now`; the table of taken addresses is kept.
    pub fn start(&mut self, now: Instant) -> Frame {
        self.cannot_claim_due = None;
        self.claim(self.preferred, now)
    }

    /// Start as [`AddressClaimer::start`] does, but send the claim only after the CA's
    /// pseudo-random delay (0..153 ms, fixed for a NAME), from [`AddressClaimer::poll`]. Until
    /// then the CA has no address and answers nothing; claims it sees still fill its table.
    pub fn start_delayed(&mut self, now: Instant) {
        self.cannot_claim_due = None;
        self.state = State::Starting { at: now.add_micros(self.random_delay_us()) };
    }

    /// Change the preferred address for the next [`AddressClaimer::start`].
    pub fn set_preferred(&mut self, preferred: Address) {
        self.preferred = preferred;
    }

    fn claim(&mut self, address: Address, now: Instant) -> Frame {
        self.state = State::Claiming { address, since: now };
        AddressClaimed { name: self.name }.frame(address)
    }

    fn cannot_claim(&mut self) -> Frame {
        self.state = State::CannotClaim;
        AddressClaimed { name: self.name }.frame(Address::NULL)
    }

    /// The next address of the range after `from`, wrapping, that is neither `from` nor taken.
    fn next_free(&self, from: Address) -> Option<Address> {
        if self.lowest > self.highest || self.highest >= Address::NULL.0 {
            return None;
        }
        let n = (self.highest - self.lowest) as u16 + 1;
        let start = if (self.lowest..=self.highest).contains(&from.0) { (from.0 - self.lowest) as u16 + 1 } else { 0 };
        (0..n).map(|k| Address(self.lowest + ((start + k) % n) as u8)).find(|&a| a != from && !self.is_taken(a))
    }

    /// The pseudo-random delay of a Cannot Claim answer and of a delayed start: 0..=255 steps
    /// of 0.6 ms from the NAME's bytes, fixed for one CA, different between CAs whose NAMEs
    /// differ in one byte.
    pub fn random_delay_us(&self) -> u64 {
        let steps = self.name.to_le_bytes().iter().fold(0u8, |a, &b| a.rotate_left(3) ^ b);
        steps as u64 * CANNOT_CLAIM_STEP_US
    }

    /// A received message. Returns the frame to send at once, if any: our claim again (a
    /// contest won, or a Request for Address Claimed), a claim of a new address (a contest
    /// lost), or Cannot Claim (lost with no address left). Messages of other groups, and
    /// malformed claims and requests, change nothing.
    pub fn on_message(&mut self, id: &Identifier, data: &[u8], now: Instant) -> Option<Frame> {
        if id.pgn() == Pgn::ADDRESS_CLAIMED {
            let claimed = AddressClaimed::parse(data).ok()?;
            self.on_claim(id.source(), claimed.name, now)
        } else if id.pgn() == Pgn::REQUEST {
            let req = Request::parse(data).ok()?;
            if req.pgn != Pgn::ADDRESS_CLAIMED {
                return None;
            }
            self.on_request(id.destination().unwrap_or(Address::GLOBAL), now)
        } else {
            None
        }
    }

    fn on_claim(&mut self, source: Address, name: Name, now: Instant) -> Option<Frame> {
        if !source.is_unicast() {
            return None; // Cannot Claim of another CA, or nonsense from FFh
        }
        if self.address() != Some(source) {
            self.mark_taken(source);
            return None;
        }
        if self.name.wins_against(name) {
            return Some(AddressClaimed { name: self.name }.frame(source));
        }
        self.mark_taken(source);
        if self.name.arbitrary_address_capable() {
            if let Some(next) = self.next_free(source) {
                return Some(self.claim(next, now));
            }
        }
        Some(self.cannot_claim())
    }

    fn on_request(&mut self, destination: Address, now: Instant) -> Option<Frame> {
        match self.state {
            State::Claiming { address, .. } | State::Claimed { address }
                if destination == Address::GLOBAL || destination == address =>
            {
                Some(AddressClaimed { name: self.name }.frame(address))
            }
            State::CannotClaim if destination == Address::GLOBAL => {
                if self.cannot_claim_due.is_none() {
                    self.cannot_claim_due = Some(now.add_micros(self.random_delay_us()));
                }
                None
            }
            _ => None,
        }
    }

    /// Time passes: a delayed start claims, the claim stands after 250 ms, a delayed Cannot
    /// Claim falls due. Returns
    /// the frame to send, if any; call again until `None`.
    pub fn poll(&mut self, now: Instant) -> Option<Frame> {
        if let State::Starting { at } = self.state {
            if now >= at {
                return Some(self.claim(self.preferred, now));
            }
        }
        if let State::Claiming { address, since } = self.state {
            if now >= since.add_millis(CONTENTION_MS) {
                self.state = State::Claimed { address };
            }
        }
        match self.cannot_claim_due {
            Some(due) if now >= due => {
                self.cannot_claim_due = None;
                if self.state == State::CannotClaim {
                    return Some(AddressClaimed { name: self.name }.frame(Address::NULL));
                }
                None
            }
            _ => None,
        }
    }

    /// When [`AddressClaimer::poll`] must next run.
    pub fn next_deadline(&self) -> Option<Instant> {
        let stand = match self.state {
            State::Starting { at } => Some(at),
            State::Claiming { since, .. } => Some(since.add_millis(CONTENTION_MS)),
            _ => None,
        };
        crate::time::earliest(stand, self.cannot_claim_due)
    }
}

#[cfg(test)]
mod tests;
