//! Address claiming in virtual time: start, the 250 ms, Requests for Address Claimed, contests
//! won and lost, moving, Cannot Claim, and a redundant pair on one bus.

use super::*;
use crate::frame::CanId;
use crate::wire::j1939::{NameFields, Priority};

/// The WV58MR's default NAME (3001h) with identity number `id`.
fn wv58mr(id: u32) -> Name {
    Name::from_fields(&NameFields {
        identity_number: id,
        manufacturer_code: 0x471,
        function: 0x8E,
        industry_group: 3,
        arbitrary_address_capable: true,
        ..NameFields::default()
    })
    .unwrap()
}

fn ms(t: u64) -> Instant {
    Instant::from_millis(t)
}

fn claimer(id: u32) -> AddressClaimer {
    AddressClaimer::new(wv58mr(id), Address(0xEF), 0x80, 0xEF)
}

/// The Address Claimed frame `name` sends from `sa`.
fn claim_frame(name: Name, sa: u8) -> Frame {
    Frame::new(CanId::Ext(0x18EE_FF00 | sa as u32), &name.to_le_bytes())
}

/// Deliver `frame` to `c`.
fn deliver(c: &mut AddressClaimer, frame: &Frame, now: Instant) -> Option<Frame> {
    let id = Identifier::from_frame(frame).unwrap();
    c.on_message(&id, frame.payload(), now)
}

fn request(da: u8, sa: u8) -> Frame {
    Request { pgn: Pgn::ADDRESS_CLAIMED }.frame(Address(da), Address(sa))
}

#[test]
fn claims_the_preferred_address_and_waits_250_ms() {
    let mut c = claimer(5);
    assert_eq!(c.state(), State::Off);
    assert_eq!(c.green_led(), LedState::Off);
    assert_eq!(c.next_deadline(), None);
    let f = c.start(ms(10));
    assert_eq!(f, Frame::new(CanId::Ext(0x18EE_FFEF), &[0x05, 0x00, 0x20, 0x8E, 0x00, 0x8E, 0x00, 0xB0]));
    assert_eq!(c.state(), State::Claiming { address: Address(0xEF), since: ms(10) });
    assert_eq!(c.address(), Some(Address(0xEF)));
    assert_eq!(c.source_address(), None);
    assert_eq!(c.green_led(), LedState::Flashing);
    assert_eq!(c.next_deadline(), Some(ms(260)));
    assert_eq!(c.poll(Instant::from_micros(259_999)), None);
    assert_eq!(c.source_address(), None);
    assert_eq!(c.poll(ms(260)), None);
    assert_eq!(c.state(), State::Claimed { address: Address(0xEF) });
    assert_eq!(c.source_address(), Some(Address(0xEF)));
    assert_eq!(c.green_led(), LedState::On);
    assert_eq!(c.next_deadline(), None);
}

#[test]
fn answers_requests_for_address_claimed_global_or_to_its_address() {
    let mut c = claimer(5);
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), ms(0)), None, "not started");
    let mine = c.start(ms(0));
    // During the contention period, and after it.
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), ms(100)), Some(mine));
    assert_eq!(deliver(&mut c, &request(0xEF, 0xFE), ms(100)), Some(mine));
    c.poll(ms(250));
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), ms(300)), Some(mine));
    assert_eq!(deliver(&mut c, &request(0xEF, 0x00), ms(300)), Some(mine));
    // Not for us, another PGN, malformed.
    assert_eq!(deliver(&mut c, &request(0x80, 0x00), ms(300)), None);
    let other = Request { pgn: Pgn::EPOS }.frame(Address::GLOBAL, Address(0));
    assert_eq!(deliver(&mut c, &other, ms(300)), None);
    assert_eq!(deliver(&mut c, &Frame::new(CanId::Ext(0x18EA_FF00), &[0x00, 0xEE]), ms(300)), None);
    // Answering does not restart the 250 ms.
    assert_eq!(c.state(), State::Claimed { address: Address(0xEF) });
}

#[test]
fn a_contest_won_repeats_the_claim_and_keeps_the_address() {
    let mut c = claimer(5);
    let mine = c.start(ms(0));
    c.poll(ms(250));
    // A higher (lower-priority) NAME claims our address.
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(6), 0xEF), ms(400)), Some(mine));
    assert_eq!(c.source_address(), Some(Address(0xEF)));
    assert!(!c.is_taken(Address(0xEF)));
    // Also while still contending: the original 250 ms continue.
    let mut d = claimer(5);
    d.start(ms(0));
    assert_eq!(deliver(&mut d, &claim_frame(wv58mr(6), 0xEF), ms(100)), Some(mine));
    assert_eq!(d.next_deadline(), Some(ms(250)));
}

#[test]
fn a_contest_lost_moves_to_the_next_free_address_and_waits_again() {
    let mut c = claimer(6);
    c.start(ms(0));
    c.poll(ms(250));
    // Others hold 80h and 81h.
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(100), 0x80), ms(300)), None);
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(101), 0x81), ms(300)), None);
    assert!(c.is_taken(Address(0x80)) && c.is_taken(Address(0x81)));
    // A lower NAME takes EFh at run time: silent at once, claim 82h (wrapping past EFh).
    let f = deliver(&mut c, &claim_frame(wv58mr(5), 0xEF), ms(500));
    assert_eq!(f, Some(claim_frame(wv58mr(6), 0x82)));
    assert_eq!(c.source_address(), None);
    assert_eq!(c.green_led(), LedState::Flashing);
    assert_eq!(c.state(), State::Claiming { address: Address(0x82), since: ms(500) });
    assert!(c.is_taken(Address(0xEF)));
    // Requests are now answered from the new address only.
    assert_eq!(deliver(&mut c, &request(0xEF, 0x00), ms(600)), None);
    assert_eq!(deliver(&mut c, &request(0x82, 0x00), ms(600)), Some(claim_frame(wv58mr(6), 0x82)));
    c.poll(ms(749));
    assert_eq!(c.source_address(), None);
    c.poll(ms(750));
    assert_eq!(c.source_address(), Some(Address(0x82)));
}

#[test]
fn an_equal_name_counts_as_lost() {
    let mut c = claimer(7);
    c.start(ms(0));
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(7), 0xEF), ms(10)), Some(claim_frame(wv58mr(7), 0x80)));
}

#[test]
fn with_no_address_left_it_sends_cannot_claim_and_stays_silent() {
    let mut c = AddressClaimer::new(wv58mr(9), Address(0x80), 0x80, 0x82);
    c.start(ms(0));
    for sa in [0x81, 0x82] {
        deliver(&mut c, &claim_frame(wv58mr(1), sa), ms(1));
    }
    let f = deliver(&mut c, &claim_frame(wv58mr(1), 0x80), ms(2));
    assert_eq!(f, Some(claim_frame(wv58mr(9), 0xFE)));
    assert_eq!(c.state(), State::CannotClaim);
    assert_eq!((c.address(), c.source_address()), (None, None));
    assert_eq!(c.green_led(), LedState::Flashing);
    assert_eq!(c.next_deadline(), None);
    assert_eq!(c.poll(ms(1000)), None);
    // A request to an address is not for us; a global one gets Cannot Claim after the delay.
    assert_eq!(deliver(&mut c, &request(0x80, 0x00), ms(1000)), None);
    assert_eq!(c.next_deadline(), None);
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), ms(1000)), None);
    let due = c.next_deadline().unwrap();
    assert!(due >= ms(1000) && due <= Instant::from_micros(1_000_000 + 255 * 600), "{due:?}");
    // A second request before it does not postpone it.
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), due), None);
    assert_eq!(c.next_deadline(), Some(due));
    if due > ms(1000) {
        assert_eq!(c.poll(ms(1000)), None);
    }
    assert_eq!(c.poll(due), Some(claim_frame(wv58mr(9), 0xFE)));
    assert_eq!(c.poll(due), None);
    assert_eq!(c.next_deadline(), None);
    // A restart (3002h.01) claims the preferred address again.
    assert_eq!(c.start(ms(2000)), claim_frame(wv58mr(9), 0x80));
}

#[test]
fn cannot_claim_delays_differ_between_names_and_stay_in_range() {
    let mut seen = [false; 256];
    for id in 0..64u32 {
        let c = claimer(id);
        let d = c.random_delay_us();
        assert!(d <= 153_000 && d.is_multiple_of(CANNOT_CLAIM_STEP_US));
        seen[(d / CANNOT_CLAIM_STEP_US) as usize] = true;
    }
    assert!(seen.iter().filter(|&&s| s).count() > 16, "delays should spread");
}

#[test]
fn a_name_without_arbitrary_address_capability_does_not_move() {
    let mut f = wv58mr(9).fields();
    f.arbitrary_address_capable = false;
    let mut c = AddressClaimer::new(Name::from_fields(&f).unwrap(), Address(0xEF), 0x80, 0xEF);
    c.start(ms(0));
    // Without the top bit our NAME is lower than any WV58MR's: a fixed-address CA wins.
    assert!(deliver(&mut c, &claim_frame(wv58mr(1), 0xEF), ms(1)).is_some());
    assert_eq!(c.address(), Some(Address(0xEF)));
    let lost = deliver(&mut c, &claim_frame(Name::from_raw(1), 0xEF), ms(1));
    assert_eq!(lost.map(|f| f.id), Some(CanId::Ext(0x18EE_FFFE)));
    assert_eq!(c.state(), State::CannotClaim);
}

#[test]
fn other_cas_cannot_claim_and_foreign_messages_change_nothing() {
    let mut c = claimer(5);
    c.start(ms(0));
    let before = c.clone();
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(1), 0xFE), ms(1)), None);
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(1), 0xFF), ms(1)), None);
    assert!(!c.is_taken(Address::NULL) && !c.is_taken(Address::GLOBAL));
    // A claim of our address that is not 8 bytes is no claim.
    assert_eq!(deliver(&mut c, &Frame::new(CanId::Ext(0x18EE_FFEF), &[0; 7]), ms(1)), None);
    // Process data from our address (someone else's bug) is no claim either.
    let epos = Identifier::pdu2(Priority::new(3).unwrap(), Pgn::EPOS, Address(0xEF)).unwrap();
    assert_eq!(c.on_message(&epos, &[0; 8], ms(1)), None);
    assert_eq!(c.state(), before.state());
    assert_eq!(c.taken, before.taken);
}

/// Two claimers on one virtual bus: every frame one sends reaches the other.
fn settle(a: &mut AddressClaimer, b: &mut AddressClaimer, mut queue: heapless::Deque<(bool, Frame), 64>, now: Instant) {
    while let Some((from_a, frame)) = queue.pop_front() {
        let dst = if from_a { &mut *b } else { &mut *a };
        if let Some(answer) = deliver(dst, &frame, now) {
            queue.push_back((!from_a, answer)).unwrap();
        }
    }
}

#[test]
fn a_redundant_pair_with_the_default_address_ends_on_two_addresses() {
    // Both channels start at EFh; their NAMEs differ in the identity number (serial).
    let mut a = claimer(1001);
    let mut b = claimer(1000);
    let mut q = heapless::Deque::new();
    q.push_back((true, a.start(ms(0)))).unwrap();
    q.push_back((false, b.start(ms(0)))).unwrap();
    settle(&mut a, &mut b, q, ms(1));
    a.poll(ms(251));
    b.poll(ms(251));
    // The lower NAME (1000) keeps EFh, the other moved to 80h.
    assert_eq!(b.source_address(), Some(Address(0xEF)));
    assert_eq!(a.source_address(), Some(Address(0x80)));
    // A global request: both answer from their addresses.
    assert_eq!(deliver(&mut a, &request(0xFF, 0x10), ms(300)), Some(claim_frame(wv58mr(1001), 0x80)));
    assert_eq!(deliver(&mut b, &request(0xFF, 0x10), ms(300)), Some(claim_frame(wv58mr(1000), 0xEF)));
}

#[test]
fn a_delayed_start_claims_after_the_names_delay() {
    let mut c = claimer(5);
    let delay = c.random_delay_us();
    assert!(delay <= 153_000);
    c.start_delayed(ms(10));
    let at = ms(10).add_micros(delay);
    assert_eq!(c.state(), State::Starting { at });
    assert_eq!((c.address(), c.source_address()), (None, None));
    assert_eq!(c.green_led(), LedState::Flashing);
    assert_eq!(c.next_deadline(), Some(at));
    // Nothing answered yet; claims seen still count.
    assert_eq!(deliver(&mut c, &request(0xFF, 0x00), ms(10)), None);
    assert_eq!(deliver(&mut c, &claim_frame(wv58mr(100), 0x80), ms(10)), None);
    assert!(c.is_taken(Address(0x80)));
    if delay > 0 {
        assert_eq!(c.poll(Instant::from_micros(at.as_micros() - 1)), None);
    }
    assert_eq!(c.poll(at), Some(claim_frame(wv58mr(5), 0xEF)));
    assert_eq!(c.state(), State::Claiming { address: Address(0xEF), since: at });
    assert_eq!(c.next_deadline(), Some(at.add_millis(250)));
}

#[test]
fn the_two_channels_of_a_pair_start_at_different_instants() {
    // Serial numbers that differ in the low byte, or in a higher one.
    for (x, y) in [(1000u32, 1001u32), (0x1234, 0x1334), (0x01_0000, 0x02_0000), (7, 8)] {
        assert_ne!(claimer(x).random_delay_us(), claimer(y).random_delay_us(), "{x:X} {y:X}");
    }
}

mod properties {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec;
    use std::vec::Vec;

    fn message() -> impl Strategy<Value = (u32, Vec<u8>, u64)> {
        let id = prop_oneof![
            (0u32..=0xFF, 0u32..=0xFF).prop_map(|(da, sa)| 0x18EA_0000 | da << 8 | sa),
            (0u32..=0xFF).prop_map(|sa| 0x18EE_FF00 | sa),
            (0x7Du32..=0xFF).prop_map(|sa| 0x18EE_FF00 | sa),
            0u32..=0x1FFF_FFFF,
        ];
        let data = prop_oneof![
            Just(vec![0x00, 0xEE, 0x00]),
            proptest::collection::vec(any::<u8>(), 8),
            proptest::collection::vec(any::<u8>(), 0..=8),
        ];
        (id, data, 0u64..400_000)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

        /// Whatever arrives, the claimer never panics, only ever sends Address Claimed with its
        /// own NAME from an address of its range or from FEh, and allows other traffic only
        /// from a claim that stood 250 ms.
        #[test]
        fn claimer_holds_its_invariants(id in 0u32..0x1F_FFFF, msgs in proptest::collection::vec(message(), 1..80)) {
            let name = wv58mr(id);
            let mut c = AddressClaimer::new(name, Address(0xEF), 0x80, 0xEF);
            let mut now = Instant::ZERO;
            let mut sent = heapless::Vec::<Frame, 256>::new();
            if id % 2 == 0 { let _ = sent.push(c.start(now)); } else { c.start_delayed(now); }
            for (raw, data, dt) in msgs {
                now = now.add_micros(dt);
                while let Some(f) = c.poll(now) { let _ = sent.push(f); }
                let frame = Frame::new(CanId::Ext(raw), &data);
                let id = Identifier::from_frame(&frame).unwrap();
                if let Some(f) = c.on_message(&id, frame.payload(), now) { let _ = sent.push(f); }
                if let State::Claiming { since, .. } = c.state() {
                    prop_assert!(c.source_address().is_none());
                    prop_assert!(now.micros_since(since) < CONTENTION_MS * 1000 || c.next_deadline() <= Some(now));
                }
                prop_assert_eq!(c.source_address().is_some(), matches!(c.state(), State::Claimed { .. }));
            }
            for f in &sent {
                let id = Identifier::from_frame(f).unwrap();
                prop_assert_eq!(id.pgn(), Pgn::ADDRESS_CLAIMED);
                prop_assert_eq!(id.destination(), Some(Address::GLOBAL));
                prop_assert_eq!(AddressClaimed::parse(f.payload()), Ok(AddressClaimed { name }));
                let sa = id.source().0;
                prop_assert!((0x80..=0xEF).contains(&sa) || sa == 0xFE, "{:02X}", sa);
            }
        }
    }
}
