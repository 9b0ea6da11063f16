//! Any frames, key presses and timing into an AP10T display, every invariant checked after
//! each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::{self, Kind};

fuzz_target!(|data: &[u8]| {
    invariants::run_kind(Kind::Ap10t, data);
});
