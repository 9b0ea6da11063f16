//! The parameter storage loader fed any flash content (first byte: the device kind).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    tests_host::invariants::run_flash(data);
});
