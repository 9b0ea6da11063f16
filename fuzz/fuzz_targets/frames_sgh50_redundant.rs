//! Any frames with any timing into either node of a redundant SGH50 (first byte: which), every invariant checked after each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::{self, Kind};

fuzz_target!(|data: &[u8]| {
    let kind = if data.first().is_some_and(|b| b & 1 != 0) { Kind::Sgh50Second } else { Kind::Sgh50First };
    invariants::run_kind(kind, data.get(1..).unwrap_or(&[]));
});
