//! Any frames with any timing into a WV5800M (first byte: 4096-turn WV or singleturn WH), every invariant checked after each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::{self, Kind};

fuzz_target!(|data: &[u8]| {
    let kind = if data.first().is_some_and(|b| b & 1 != 0) { Kind::Wh5800mSingle } else { Kind::Wv5800m };
    invariants::run_kind(kind, data.get(1..).unwrap_or(&[]));
});
