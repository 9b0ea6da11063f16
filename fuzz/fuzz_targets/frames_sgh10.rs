//! Any frames with any timing into an SGH10 node, every invariant checked after each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::{self, Kind};

fuzz_target!(|data: &[u8]| {
    invariants::run_kind(Kind::Sgh10, data);
});
