//! The stress checker (`tests_host::invariants`) on stable: any sequence of frames with any
//! timing into a node of every device kind, every invariant checked after every input.
//! `PROPTEST_CASES` sets the number of cases (default 256).

use od_core::{CanId, Frame};
use proptest::prelude::*;
use tests_host::invariants::j1939::{run_j1939, J1939Rig, TURNS};
use tests_host::invariants::{run_case, Action, Kind, Rig, KINDS};

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), max_shrink_iters: 2000, ..ProptestConfig::default() })]

    /// Random bytes decoded into actions biased toward the node's own identifiers, on every
    /// CANopen kind, the AP10T included.
    #[test]
    fn any_input_keeps_every_invariant(kind in 0..KINDS.len() as u8, node in any::<u8>(), body in proptest::collection::vec(any::<u8>(), 0..3000)) {
        let mut data = vec![kind, node];
        data.extend_from_slice(&body);
        run_case(&data);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), max_shrink_iters: 2000, ..ProptestConfig::default() })]

    /// The same for the WV58MR, a J1939 node: any frames with any timing, CAM21 parameter
    /// access, Requests, address contests, its 3002h commands, stores and power cycles.
    #[test]
    fn j1939_any_input_keeps_every_invariant(body in proptest::collection::vec(any::<u8>(), 0..3000)) {
        run_j1939(&body);
    }
}

/// Found by the proptest in CI: an AP10T in OPERATIONAL whose external heartbeat (5F09h) runs
/// out while a 1010h save waits for the store drops to PRE-OPERATIONAL (D-AP-19); the save is
/// still answered when the store is done, as it must be (the SDO server is not reset).
#[test]
fn ap10t_save_answered_over_an_external_heartbeat_timeout() {
    let mut data = vec![6, 0];
    data.extend_from_slice(&AP10T_SAVE_OVER_TIMEOUT);
    run_case(&data);
}

/// Found by the proptest on main: an AP10T at the factory node-ID 7Dh gets a 1010h save, whose
/// waiting answer an NMT Reset Communication drops while the store goes on; then a 5F0Ah.02
/// write starts an Auto-ID. The store's result answered the Auto-ID (`60 0A 5F 02`) before any
/// key. A 5F0Ah.02 write while a store is under way is now refused with 08000022h (D-AP-25).
#[test]
fn ap10t_auto_id_not_answered_by_a_dropped_save() {
    let mut data = vec![6, 0];
    data.extend_from_slice(&AP10T_AUTO_ID_OVER_A_DROPPED_SAVE);
    run_case(&data);
}

/// The same, directed: the Auto-ID write during the dropped save's store is refused (08000022h),
/// the store's result answers nothing, and an Auto-ID after it waits for its key as before.
#[test]
fn ap10t_auto_id_refused_while_a_store_is_under_way() {
    let mut rig = Rig::new(Kind::Ap10t, Some(0x7D));
    let nmt = |d: [u8; 2]| Action::Frame(Frame::std(0, &d));
    let sdo = |d: [u8; 8]| Action::Frame(Frame::std(0x67D, &d));
    let auto_id = [0x2F, 0x0A, 0x5F, 0x02, 0x05, 0, 0, 0];
    for a in [
        Action::Advance(0),
        nmt([0x80, 0x00]),
        Action::Advance(1_000_000),
        sdo([0x23, 0x10, 0x10, 0x03, b's', b'a', b'v', b'e']),
        nmt([0x82, 0x7D]),
        Action::Advance(1_000),
    ] {
        rig.apply(a).unwrap();
    }
    assert_eq!(rig.node().core().node_id, 0x7D);
    assert_eq!(rig.sdo_answer(auto_id).unwrap(), [0x80, 0x0A, 0x5F, 0x02, 0x22, 0x00, 0x00, 0x08]);
    rig.apply(Action::StoreDone(true)).unwrap();
    // The store is done: the Auto-ID waits for its key (no answer yet).
    assert!(rig.sdo_answer(auto_id).is_err(), "the Auto-ID answers at its key");
    rig.settle().unwrap();
}

/// Found by the J1939 proptest (shrunk by hand further): a WV58MR whose claim stood gets a
/// segmented CAM21 download of 3000h.06 (initiate without a size, then one last segment with
/// 00h); EPOS went on at priority 3 because only an initiate download reached the scheduler
/// (D-J1939-28). The same for any 3000h entry, e.g. Proprietary B at the old 3000h.04.
#[test]
fn wv58mr_segmented_write_of_a_priority_reaches_the_cyclic_groups() {
    run_j1939(&WV58MR_SEGMENTED_PRIORITY);
}

/// The shape of the first report (Proprietary B, 18FFAAEFh, at the old priority): 3000h.01 :=
/// 100 ms expedited, then 3000h.04 := 2 segmented; every Proprietary B after it is at 2.
#[test]
fn wv58mr_proprietary_b_priority_written_segmented() {
    let mut rig = J1939Rig::new(TURNS[0], 0x1_2345, None);
    let cam = |d: [u8; 8]| Action::Frame(Frame::new(CanId::Ext(0x1C06_EF00), &d));
    let actions = [
        Action::Advance(1_000_000),
        cam([0x2B, 0x00, 0x30, 0x01, 0x64, 0x00, 0x00, 0x00]),
        cam([0x21, 0x00, 0x30, 0x04, 0x01, 0x00, 0x00, 0x00]),
        cam([0x0D, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]),
        Action::Advance(300_000),
    ];
    for (n, a) in actions.into_iter().enumerate() {
        rig.apply(a).unwrap_or_else(|v| panic!("action {n}: {v}"));
    }
    rig.settle().unwrap();
}

const WV58MR_SEGMENTED_PRIORITY: [u8; 23] =
    [0, 0, 45, 183, 227, 0, 83, 7, 0, 226, 40, 131, 159, 0, 131, 0, 65, 51, 0, 0, 97, 9, 43];

const AP10T_SAVE_OVER_TIMEOUT: [u8; 535] = [
    229, 242, 85, 117, 107, 183, 0, 144, 253, 165, 87, 110, 227, 239, 181, 103, 204, 191, 238, 204, 203, 39, 226, 71,
    233, 87, 88, 144, 254, 46, 133, 65, 92, 148, 224, 64, 204, 166, 201, 12, 247, 25, 54, 27, 152, 213, 85, 205, 238,
    13, 1, 50, 235, 163, 20, 57, 48, 71, 84, 163, 24, 19, 173, 156, 8, 158, 136, 204, 237, 238, 25, 94, 36, 153, 176,
    205, 65, 206, 14, 107, 105, 247, 213, 6, 193, 66, 43, 146, 244, 152, 106, 93, 114, 89, 251, 25, 210, 155, 66, 220,
    35, 70, 247, 11, 31, 233, 140, 209, 145, 118, 255, 111, 55, 97, 113, 38, 179, 112, 70, 85, 46, 249, 53, 143, 10,
    136, 172, 128, 191, 147, 44, 126, 29, 160, 124, 203, 156, 196, 216, 246, 241, 101, 18, 177, 201, 201, 184, 186, 42,
    202, 201, 88, 142, 62, 99, 1, 254, 70, 214, 233, 84, 197, 180, 54, 184, 28, 12, 4, 158, 63, 127, 177, 69, 45, 98,
    213, 205, 147, 57, 219, 11, 201, 78, 120, 134, 33, 9, 78, 118, 132, 203, 47, 102, 207, 203, 177, 158, 4, 138, 106,
    85, 60, 106, 19, 28, 67, 60, 196, 42, 72, 167, 6, 160, 78, 169, 37, 8, 68, 43, 212, 193, 229, 117, 117, 95, 192,
    228, 20, 167, 42, 219, 105, 152, 212, 219, 20, 133, 221, 255, 183, 171, 57, 147, 95, 186, 134, 247, 97, 5, 183,
    191, 131, 216, 23, 236, 24, 171, 35, 86, 168, 183, 59, 77, 77, 22, 202, 153, 50, 11, 33, 83, 195, 237, 230, 34, 58,
    39, 138, 111, 173, 162, 183, 251, 197, 2, 206, 47, 26, 67, 32, 5, 217, 143, 52, 231, 129, 104, 247, 220, 208, 249,
    157, 193, 221, 214, 66, 55, 245, 66, 46, 164, 192, 23, 183, 215, 188, 250, 254, 61, 150, 79, 229, 90, 85, 145, 173,
    15, 230, 218, 97, 209, 167, 57, 12, 132, 215, 156, 192, 163, 161, 3, 44, 203, 199, 8, 118, 23, 148, 83, 28, 221,
    156, 182, 124, 156, 12, 53, 93, 153, 230, 206, 194, 11, 218, 105, 235, 165, 20, 203, 143, 107, 164, 52, 14, 123,
    38, 38, 59, 1, 39, 201, 25, 54, 183, 253, 98, 199, 159, 146, 235, 182, 163, 161, 4, 235, 96, 205, 181, 122, 39, 67,
    115, 150, 54, 9, 45, 115, 137, 17, 68, 120, 133, 236, 245, 93, 182, 128, 20, 212, 94, 143, 89, 2, 247, 86, 117,
    157, 181, 21, 124, 103, 180, 224, 59, 83, 62, 147, 27, 12, 164, 36, 139, 200, 235, 40, 122, 250, 7, 207, 181, 107,
    56, 68, 214, 50, 30, 226, 197, 240, 254, 192, 101, 7, 134, 66, 160, 235, 227, 62, 108, 173, 196, 38, 82, 88, 47,
    56, 47, 243, 161, 40, 109, 24, 98, 246, 69, 109, 175, 117, 79, 222, 184, 253, 21, 106, 209, 239, 221, 126, 242,
    240, 143, 121, 53, 244, 61, 239, 0, 162, 74, 186, 221, 125, 142, 123, 25, 190, 111, 157, 33, 226, 122, 107, 190,
    56, 241, 144, 242, 115, 191, 9, 67, 230, 109, 109,
];

const AP10T_AUTO_ID_OVER_A_DROPPED_SAVE: [u8; 712] = [
    182, 151, 141, 172, 45, 240, 84, 39, 158, 96, 239, 17, 14, 217, 123, 34, 95, 231, 235, 94, 109, 35, 50, 111, 7, 60,
    141, 200, 94, 210, 52, 95, 135, 1, 84, 114, 169, 200, 121, 86, 140, 111, 166, 199, 209, 146, 107, 1, 178, 231, 11,
    12, 134, 238, 182, 143, 111, 190, 126, 77, 93, 181, 25, 66, 131, 221, 178, 137, 14, 245, 23, 122, 222, 45, 157, 60,
    171, 248, 129, 49, 173, 99, 199, 172, 129, 212, 207, 133, 250, 31, 28, 167, 166, 231, 154, 141, 207, 126, 21, 175,
    0, 202, 128, 143, 222, 168, 169, 94, 212, 53, 1, 20, 87, 193, 0, 95, 100, 133, 108, 228, 100, 51, 23, 121, 107, 84,
    67, 86, 57, 131, 140, 67, 226, 89, 66, 3, 200, 220, 201, 218, 36, 193, 193, 95, 134, 99, 37, 32, 243, 219, 51, 40,
    196, 200, 189, 82, 239, 125, 155, 202, 25, 42, 180, 30, 102, 140, 186, 222, 228, 163, 126, 124, 185, 172, 15, 31,
    114, 91, 163, 203, 27, 51, 249, 8, 227, 22, 211, 57, 112, 57, 117, 68, 59, 150, 75, 19, 168, 73, 177, 162, 232,
    201, 87, 240, 178, 250, 228, 61, 212, 133, 168, 13, 8, 18, 149, 169, 198, 229, 105, 36, 146, 59, 172, 178, 183,
    169, 113, 29, 103, 163, 63, 13, 71, 197, 12, 120, 98, 132, 183, 87, 163, 185, 96, 21, 164, 94, 94, 75, 158, 237,
    247, 123, 111, 216, 205, 23, 16, 202, 0, 24, 42, 17, 134, 108, 49, 156, 51, 8, 92, 233, 223, 116, 6, 246, 230, 152,
    15, 204, 253, 167, 79, 168, 8, 22, 226, 170, 92, 87, 122, 31, 168, 146, 5, 237, 158, 224, 9, 35, 99, 94, 195, 228,
    243, 71, 60, 158, 249, 79, 69, 12, 74, 88, 21, 7, 165, 94, 89, 187, 234, 155, 247, 146, 13, 24, 156, 216, 47, 22,
    16, 126, 203, 196, 74, 199, 169, 250, 206, 77, 223, 180, 211, 158, 189, 90, 38, 38, 5, 196, 178, 181, 203, 161,
    180, 229, 153, 42, 5, 65, 95, 122, 59, 166, 136, 57, 107, 42, 8, 190, 82, 213, 130, 158, 11, 109, 105, 190, 180,
    12, 189, 141, 214, 63, 75, 202, 73, 6, 104, 28, 183, 152, 203, 179, 140, 162, 2, 214, 63, 210, 103, 188, 203, 59,
    128, 50, 171, 33, 173, 95, 21, 208, 10, 155, 22, 148, 131, 182, 106, 153, 183, 233, 109, 210, 195, 34, 235, 8, 175,
    149, 81, 194, 157, 171, 90, 5, 151, 222, 157, 244, 6, 24, 194, 211, 187, 38, 77, 131, 99, 179, 159, 88, 119, 195,
    41, 171, 230, 230, 171, 190, 141, 196, 2, 112, 65, 169, 87, 102, 172, 253, 140, 70, 172, 194, 172, 192, 32, 13,
    123, 78, 234, 30, 248, 238, 175, 83, 39, 113, 143, 254, 42, 53, 195, 241, 178, 163, 89, 192, 175, 238, 154, 130,
    245, 194, 78, 41, 96, 16, 140, 97, 58, 191, 145, 132, 60, 192, 255, 199, 64, 156, 252, 20, 24, 127, 40, 66, 210,
    122, 141, 226, 49, 238, 160, 108, 28, 110, 140, 2, 85, 227, 124, 144, 215, 172, 177, 183, 153, 210, 50, 172, 232,
    78, 19, 162, 31, 224, 3, 122, 241, 149, 154, 9, 33, 139, 132, 28, 32, 185, 223, 84, 102, 124, 245, 103, 69, 234,
    218, 242, 72, 30, 98, 249, 215, 125, 172, 204, 178, 245, 227, 32, 175, 188, 127, 198, 131, 186, 68, 96, 8, 90, 161,
    105, 106, 152, 22, 122, 43, 192, 115, 249, 189, 87, 23, 155, 242, 86, 30, 162, 128, 217, 58, 118, 150, 108, 104,
    21, 68, 52, 86, 88, 24, 237, 196, 176, 193, 29, 120, 189, 133, 39, 167, 167, 178, 252, 195, 134, 60, 211, 125, 78,
    1, 12, 26, 82, 195, 253, 103, 170, 171, 155, 17, 47, 23, 81, 186, 204, 187, 163, 165, 45, 52, 2, 172, 76, 70, 151,
    191, 110, 90, 235, 71, 149, 89, 203, 236, 14, 216, 40, 107, 229, 66, 25, 12, 225, 82, 41, 142, 58, 209, 188, 131,
    93, 175, 16, 28, 204, 189, 152, 95, 199, 35, 84, 102, 112,
];

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

    /// The WV58MR's generator reaches its deep states: claims standing, contests won and lost,
    /// Cannot Claim, Requests answered, CAM21 transfers (segmented ones completed, timeouts),
    /// saves checked at power-on.
    #[test]
    fn random_bytes_reach_deep_states_on_the_wv58mr() {
        use tests_host::invariants::j1939::{run_j1939, J1939Stats};
        let mut t = J1939Stats::default();
        for seed in 0..40u64 {
            let mut data = vec![seed as u8, (seed % 3) as u8];
            data.extend(bytes(seed * 31 + 7, 3000));
            let s = run_j1939(&data);
            t.inputs += s.inputs;
            t.frames_in += s.frames_in;
            t.frames_out += s.frames_out;
            t.cam_answers += s.cam_answers;
            t.sdo_timeouts += s.sdo_timeouts;
            t.requests_answered += s.requests_answered;
            t.contests_lost += s.contests_lost;
            t.contests_won += s.contests_won;
            t.cannot_claim += s.cannot_claim;
            t.claims_stood += s.claims_stood;
            t.stores += s.stores;
            t.power_cycles += s.power_cycles;
            t.segmented_done += s.segmented_done;
        }
        eprintln!("WV58MR: {t:?}");
        assert!(t.claims_stood > 40 && t.contests_won > 0 && t.contests_lost > 0 && t.cannot_claim > 0, "{t:?}");
        assert!(t.requests_answered > 0 && t.cam_answers > 0 && t.segmented_done > 0 && t.sdo_timeouts > 0, "{t:?}");
        assert!(t.stores > 0 && t.power_cycles > 40, "{t:?}");
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
