//! The simulator's socketcand message splitter and parser fed any bytes (NUL splits reads).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    tests_host::invariants::run_socketcand(data);
});
