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
