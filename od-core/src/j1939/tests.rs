//! The J1939 pieces together, as a redundant WV58MR's two channels use them on one virtual
//! bus: both start with address EFh after their power-up delays, one has to move, and both
//! publish EPOS and ESPD from their own addresses every 50 ms once their claims have stood,
//! never before; a Request for Address Claimed is answered by both.

extern crate std;
use std::vec::Vec;

use super::claim::{AddressClaimer, State};
use super::request::{self, Response};
use super::schedule::{Cyclic, Scheduler};
use crate::frame::Frame;
use crate::time::{earliest, Instant};
use crate::wire::j1939::{Address, Epos, Espd, Identifier, Message, Name, NameFields, Payload, Pgn, Priority, Request};

/// One channel: its claimer, its cyclic groups and the position it reports.
struct Channel {
    claim: AddressClaimer,
    cyclic: Scheduler<3>,
    position: u32,
}

const PROVIDED: [Pgn; 3] = [Pgn::EPOS, Pgn::ESPD, Pgn::PROPRIETARY_B];

impl Channel {
    fn new(serial: u32, position: u32) -> Channel {
        let name = Name::from_fields(&NameFields {
            identity_number: NameFields::identity_from_serial(serial),
            manufacturer_code: 0x471,
            function: 0x8E,
            industry_group: 3,
            arbitrary_address_capable: true,
            ..NameFields::default()
        })
        .unwrap();
        let p = |n| Priority::new(n).unwrap();
        Channel {
            claim: AddressClaimer::new(name, Address(0xEF), 0x80, 0xEF),
            cyclic: Scheduler::new([
                Cyclic::new(Pgn::PROPRIETARY_B, 0, p(6)),
                Cyclic::new(Pgn::ESPD, 50, p(3)),
                Cyclic::new(Pgn::EPOS, 50, p(3)),
            ]),
            position,
        }
    }

    fn group(&self, pgn: Pgn, priority: Priority) -> Option<Frame> {
        let id = Identifier::pdu2(priority, pgn, self.claim.source_address()?)?;
        match pgn {
            Pgn::EPOS => Some(id.frame(&Epos { position: self.position }.emit())),
            Pgn::ESPD => Some(id.frame(&Espd { speed: 0 }.emit())),
            _ => None,
        }
    }

    /// Time passes: what the channel sends at `now`.
    fn poll(&mut self, now: Instant, out: &mut Vec<Frame>) {
        out.extend(self.claim.poll(now));
        match (self.claim.source_address(), self.cyclic.is_running()) {
            (Some(_), false) => self.cyclic.start(now),
            (None, true) => self.cyclic.stop(),
            _ => {}
        }
        while let Some(due) = self.cyclic.poll(now) {
            out.extend(self.group(due.pgn, due.priority));
        }
    }

    /// A frame from the bus: what the channel answers.
    fn receive(&mut self, frame: &Frame, now: Instant, out: &mut Vec<Frame>) {
        let Ok(id) = Identifier::from_frame(frame) else { return };
        out.extend(self.claim.on_message(&id, frame.payload(), now));
        match request::respond(&id, frame.payload(), self.claim.source_address(), &PROVIDED) {
            Response::Send { pgn, .. } => out.extend(self.group(pgn, Priority::new(3).unwrap())),
            Response::Nack(f) => out.push(f),
            Response::AddressClaim | Response::Ignore => {}
        }
        if self.claim.source_address().is_none() && self.cyclic.is_running() {
            self.cyclic.stop();
        }
    }

    fn next_deadline(&self) -> Option<Instant> {
        earliest(self.claim.next_deadline(), self.cyclic.next_deadline())
    }
}

/// Run the channels (and frames injected at given instants) to `end`; every frame on the bus
/// with its time. A frame reaches every channel but its sender.
fn run(chs: &mut [Channel], inject: &[(Instant, Frame)], end: Instant) -> Vec<(Instant, Frame)> {
    let mut trace = Vec::new();
    let mut now = Instant::ZERO;
    loop {
        let mut sent: Vec<(usize, Frame)> = Vec::new();
        for (i, c) in chs.iter_mut().enumerate() {
            let mut out = Vec::new();
            c.poll(now, &mut out);
            sent.extend(out.into_iter().map(|f| (i, f)));
        }
        sent.extend(inject.iter().filter(|(t, _)| *t == now).map(|(_, f)| (usize::MAX, *f)));
        while !sent.is_empty() {
            let mut next = Vec::new();
            for (from, f) in sent {
                trace.push((now, f));
                for (i, c) in chs.iter_mut().enumerate().filter(|(i, _)| *i != from) {
                    let mut out = Vec::new();
                    c.receive(&f, now, &mut out);
                    next.extend(out.into_iter().map(|f| (i, f)));
                }
            }
            sent = next;
        }
        let due = chs
            .iter()
            .filter_map(Channel::next_deadline)
            .chain(inject.iter().map(|(t, _)| *t).filter(|t| *t > now))
            .min();
        match due {
            Some(t) if t <= end => now = t,
            _ => return trace,
        }
    }
}

fn source(f: &Frame) -> u8 {
    Identifier::from_frame(f).unwrap().source().0
}

#[test]
fn a_redundant_pair_claims_moves_and_publishes() {
    let mut chs = [Channel::new(20_001, 111), Channel::new(20_000, 222)];
    let starts: Vec<Instant> = chs
        .iter_mut()
        .map(|c| {
            c.claim.start_delayed(Instant::ZERO);
            c.claim.next_deadline().unwrap()
        })
        .collect();
    assert_ne!(starts[0], starts[1], "the channels' first claims do not coincide");
    let request = Request { pgn: Pgn::ADDRESS_CLAIMED }.frame(Address::GLOBAL, Address(0x10));
    let trace = run(&mut chs, &[(Instant::from_millis(700), request)], Instant::from_millis(1000));

    // Serial 20000 has the lower NAME: it keeps EFh, the other channel moves to 80h.
    assert_eq!(chs[1].claim.state(), State::Claimed { address: Address(0xEF) });
    assert_eq!(chs[0].claim.state(), State::Claimed { address: Address(0x80) });
    let claims: Vec<(Instant, u8, Name)> = trace
        .iter()
        .filter_map(|(t, f)| match Message::parse(f).map(|m| m.payload) {
            Ok(Payload::AddressClaimed(c)) => Some((*t, source(f), c.name)),
            _ => None,
        })
        .collect();
    // Both claimed EFh first; the higher NAME then claimed 80h.
    let (n0, n1) = (chs[0].claim.name(), chs[1].claim.name());
    assert!(claims.iter().any(|&(_, sa, n)| sa == 0xEF && n == n0), "{claims:?}");
    assert!(claims.iter().any(|&(_, sa, n)| sa == 0xEF && n == n1), "{claims:?}");
    assert!(claims.iter().any(|&(_, sa, n)| sa == 0x80 && n == n0), "{claims:?}");
    assert!(!claims.iter().any(|&(_, sa, n)| sa == 0x80 && n == n1), "{claims:?}");

    for (ch, sa, position) in [(0usize, 0x80u8, 111u32), (1, 0xEF, 222)] {
        // The claim the channel kept, and when it was sent.
        let name = chs[ch].claim.name();
        let kept = claims.iter().filter(|&&(_, s, n)| s == sa && n == name).map(|&(t, _, _)| t).next().unwrap();
        let epos: Vec<Instant> = trace
            .iter()
            .filter(|(_, f)| source(f) == sa && Message::parse(f).unwrap().id.pgn() == Pgn::EPOS)
            .map(|(t, f)| {
                assert_eq!(Message::parse(f).unwrap().payload, Payload::Epos(Epos { position }), "channel {ch}");
                *t
            })
            .collect();
        // Nothing before the claim stood 250 ms, then every 50 ms.
        assert_eq!(epos.first().copied(), Some(kept.add_millis(250)), "channel {ch}");
        assert!(epos.windows(2).all(|w| w[1].micros_since(w[0]) == 50_000), "channel {ch}: {epos:?}");
        assert!(epos.len() >= 10, "channel {ch}: {}", epos.len());
        // Nothing but claims from either channel before its claim stood.
        assert!(trace.iter().all(|(t, f)| *t >= kept.add_millis(250)
            || source(f) != sa
            || Identifier::from_frame(f).unwrap().pgn() == Pgn::ADDRESS_CLAIMED));
    }
    // The global Request for Address Claimed at 700 ms: both answer from their addresses.
    let answers: Vec<u8> = trace
        .iter()
        .filter(|(t, f)| {
            *t == Instant::from_millis(700) && Identifier::from_frame(f).unwrap().pgn() == Pgn::ADDRESS_CLAIMED
        })
        .map(|(_, f)| source(f))
        .collect();
    assert_eq!(answers.len(), 2);
    assert!(answers.contains(&0x80) && answers.contains(&0xEF));
}

#[test]
fn a_channel_silenced_by_a_contest_at_run_time_restarts_after_its_new_claim_stood() {
    let mut chs = [Channel::new(5, 1)];
    chs[0].claim.start(Instant::ZERO);
    // At 500 ms a CA with a lower NAME claims EFh.
    let intruder = crate::wire::j1939::AddressClaimed { name: Name::from_raw(0x10) }.frame(Address(0xEF));
    let trace = run(&mut chs, &[(Instant::from_millis(500), intruder)], Instant::from_millis(1000));
    let epos: Vec<(u64, u8)> = trace
        .iter()
        .filter(|(_, f)| Identifier::from_frame(f).unwrap().pgn() == Pgn::EPOS)
        .map(|(t, f)| (t.as_millis(), source(f)))
        .collect();
    // From EFh up to 500 ms (the frame due at 500 ms left before the intruder's claim), then
    // silence until the claim of 80h has stood, from 750 ms.
    assert!(epos.iter().filter(|e| e.1 == 0xEF).all(|e| e.0 <= 500));
    assert_eq!(epos.iter().find(|e| e.1 == 0x80), Some(&(750, 0x80)));
    assert!(epos.iter().all(|e| e.0 <= 500 || e.0 >= 750));
}
