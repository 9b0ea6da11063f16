//! Any frames with any timing into a non-redundant SGH50 node, every invariant checked after each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::{self, Kind};

fuzz_target!(|data: &[u8]| {
    invariants::run_kind(Kind::Sgh50Single, data);
});
