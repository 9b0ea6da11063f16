//! The stress checker (`tests_host::invariants`) on stable: any sequence of frames with any
//! timing into a node of every device kind, every invariant checked after every input.
//! `PROPTEST_CASES` sets the number of cases (default 256).

use proptest::prelude::*;
use tests_host::invariants::{run_case, KINDS};

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), max_shrink_iters: 2000, ..ProptestConfig::default() })]

    /// Random bytes decoded into actions biased toward the node's own identifiers.
    #[test]
    fn any_input_keeps_every_invariant(kind in 0..KINDS.len() as u8, node in any::<u8>(), body in proptest::collection::vec(any::<u8>(), 0..3000)) {
        let mut data = vec![kind, node];
        data.extend_from_slice(&body);
        run_case(&data);
    }
}

mod depth {
    use tests_host::invariants::{Rig, Stats, KINDS};

    /// Deterministic bytes (xorshift), so the figures are reproducible.
    pub fn bytes(seed: u64, n: usize) -> Vec<u8> {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 24) as u8
            })
            .collect()
    }

    /// The generator reaches the deep states on every kind: segmented transfers completed,
    /// SDO timeouts, saves carried out and checked at power-on, LSS configuration.
    #[test]
    fn random_bytes_reach_deep_states_on_every_kind() {
        for (k, &kind) in KINDS.iter().enumerate() {
            let mut total = Stats::default();
            for seed in 0..40u64 {
                let mut rig = Rig::new(kind, Some(1 + (seed % 127) as u8));
                rig.run_bytes(&bytes(seed * 31 + k as u64, 3000)).unwrap_or_else(|v| panic!("{}: {v}", kind.name()));
                let s = rig.stats;
                total.inputs += s.inputs;
                total.frames_in += s.frames_in;
                total.frames_out += s.frames_out;
                total.sdo_answers += s.sdo_answers;
                total.sdo_timeouts += s.sdo_timeouts;
                total.stores += s.stores;
                total.power_cycles += s.power_cycles;
                total.lss_configuration += s.lss_configuration;
                total.segmented_done += s.segmented_done;
            }
            eprintln!("{}: {total:?}", kind.name());
            if kind.segmented_sdo() {
                assert!(total.segmented_done > 0, "{}: no segmented download completed", kind.name());
                assert!(total.sdo_timeouts > 0, "{}: no SDO timeout", kind.name());
            } else {
                assert!(total.segmented_done == 0, "{}: a segmented download on an expedited server", kind.name());
            }
            assert!(total.stores > 0, "{}: no store", kind.name());
            if kind.has_lss() {
                assert!(total.lss_configuration > 0, "{}: never in LSS configuration", kind.name());
            } else {
                assert!(total.lss_configuration == 0, "{}: in LSS configuration without LSS", kind.name());
            }
            assert!(total.power_cycles > 40, "{}: no power cycle besides the final ones", kind.name());
        }
    }
}

/// The checker catches each fault it is meant to catch: a node wrapped in a faulty shell.
mod checker_fails {
    use std::collections::VecDeque;

    use od_core::encoder::SensorFault;
    use od_core::lss::Lss;
    use od_core::node::{BusEvent, Core, Output};
    use od_core::od::GroupMask;
    use od_core::output::OUTBOX_DEPTH;
    use od_core::{CanId, Frame, Instant, NmtState};
    use tests_host::encoder::upload_request;
    use tests_host::invariants::{Action, Kind, Rig, Subject, Wrap};

    /// What the faulty shell does wrong.
    #[derive(Clone, Copy, PartialEq)]
    enum Fault {
        ForeignFrame,
        DoubleAnswer,
        SwallowAnswer,
        SpuriousStore,
        NoTimeout,
        NoBootUp,
        /// Hands the node a burst of SDO requests in one call, as a shell that does not drain
        /// after every frame would (the outbox overflows).
        Burst,
    }

    struct Faulty {
        inner: Box<dyn Subject>,
        fault: Fault,
        polling: bool,
        extra: VecDeque<Output>,
    }

    impl Subject for Faulty {
        fn on_frame(&mut self, frame: &Frame, now: Instant) {
            self.polling = false;
            self.inner.on_frame(frame, now);
            if self.fault == Fault::Burst && frame.id == CanId::Std(0x605) {
                for _ in 0..OUTBOX_DEPTH {
                    self.inner.on_frame(frame, now);
                }
            }
            if self.fault == Fault::ForeignFrame && frame.id == CanId::Std(0x80) {
                self.extra.push_back(Output::Frame(Frame::std(0x123, &[1])));
            }
        }
        fn poll(&mut self, now: Instant) {
            self.polling = true;
            self.inner.poll(now)
        }
        fn next_deadline(&self) -> Option<Instant> {
            self.inner.next_deadline()
        }
        fn next_output(&mut self) -> Option<Output> {
            if let Some(o) = self.extra.pop_front() {
                return Some(o);
            }
            loop {
                let out = self.inner.next_output()?;
                let Output::Frame(f) = out else { return Some(out) };
                let sdo = f.id.raw() & 0x780 == 0x580;
                match self.fault {
                    Fault::DoubleAnswer if sdo => self.extra.push_back(out),
                    Fault::SwallowAnswer if sdo => continue,
                    Fault::NoTimeout if sdo && self.polling => continue,
                    Fault::NoBootUp if f.id.raw() & 0x780 == 0x700 && f.payload() == [0] => continue,
                    _ => {}
                }
                return Some(out);
            }
        }
        fn store_done(&mut self, ok: bool, now: Instant) {
            self.inner.store_done(ok, now)
        }
        fn on_bus_event(&mut self, event: BusEvent, now: Instant) {
            self.inner.on_bus_event(event, now)
        }
        fn sample(&mut self, raw: Result<u32, SensorFault>, now: Instant) {
            self.polling = false;
            self.inner.sample(raw, now);
            if self.fault == Fault::SpuriousStore {
                self.extra.push_back(Output::Store(GroupMask::ALL));
            }
        }
        fn core(&self) -> &Core {
            self.inner.core()
        }
        fn lss(&self) -> &Lss {
            self.inner.lss()
        }
        fn nmt_state(&self) -> NmtState {
            self.inner.nmt_state()
        }
    }

    fn wrap(fault: Fault) -> Wrap {
        macro_rules! w {
            ($f:expr) => {
                |inner| Box::new(Faulty { inner, fault: $f, polling: false, extra: VecDeque::new() })
            };
        }
        match fault {
            Fault::ForeignFrame => w!(Fault::ForeignFrame),
            Fault::DoubleAnswer => w!(Fault::DoubleAnswer),
            Fault::SwallowAnswer => w!(Fault::SwallowAnswer),
            Fault::SpuriousStore => w!(Fault::SpuriousStore),
            Fault::NoTimeout => w!(Fault::NoTimeout),
            Fault::NoBootUp => w!(Fault::NoBootUp),
            Fault::Burst => w!(Fault::Burst),
        }
    }

    /// Runs `actions` on an SGH10 (node 5) in a shell with `fault`; returns the violation.
    fn violation(fault: Fault, actions: &[Action]) -> String {
        let mut rig = Rig::wrapped(Kind::Sgh10, Some(5), wrap(fault));
        for a in actions {
            if let Err(v) = rig.apply(*a) {
                return v.0;
            }
        }
        panic!("the checker missed the fault");
    }

    const BOOT: Action = Action::Advance(0);
    fn sdo(req: [u8; 8]) -> Action {
        Action::Frame(Frame::std(0x605, &req))
    }

    #[test]
    fn each_fault_is_caught() {
        let v = violation(Fault::ForeignFrame, &[BOOT, Action::Frame(Frame::std(0x80, &[]))]);
        assert!(v.contains("not an identifier it owns"), "{v}");
        let v = violation(Fault::DoubleAnswer, &[BOOT, sdo(upload_request(0x1000, 0))]);
        assert!(v.contains("2 SDO answers"), "{v}");
        let v = violation(Fault::SwallowAnswer, &[BOOT, sdo(upload_request(0x1000, 0))]);
        assert!(v.contains("unanswered"), "{v}");
        let v = violation(Fault::SpuriousStore, &[BOOT, Action::Sample(Ok(1000))]);
        assert!(v.contains("without a request"), "{v}");
        // 1008h (a string) opens a segmented upload; the client then falls silent.
        let v = violation(Fault::NoTimeout, &[BOOT, sdo(upload_request(0x1008, 0)), Action::Advance(2_000_000)]);
        assert!(v.contains("not aborted"), "{v}");
        let v = violation(Fault::NoBootUp, &[BOOT]);
        assert!(v.contains("without a boot-up"), "{v}");
        let v = violation(Fault::Burst, &[BOOT, sdo(upload_request(0x1000, 0))]);
        assert!(v.contains("outbox dropped"), "{v}");
    }
}
