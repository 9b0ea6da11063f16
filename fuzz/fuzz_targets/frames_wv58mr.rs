//! Any frames with any timing into a WV58MR channel (a J1939 node): CAM21 parameter access,
//! Requests, address contests, its 3002h commands, stores, bus events, sensor samples and power
//! cycles, every invariant checked after each input.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tests_host::invariants::j1939;

fuzz_target!(|data: &[u8]| {
    j1939::run_j1939(data);
});
