//! Cost of an idle tick: `Node::poll` at a time when nothing is due, N times.
//!
//! An SGH10 (node-ID 1) in OPERATIONAL with a heartbeat of 1000 ms, polled N times at the same
//! instant just after start-up, when no heartbeat, SDO or PDO timer is due. Run under
//! callgrind with two values of N and divide the difference by the difference of N:
//!
//! ```sh
//! cargo build --release -p tests-host --example idle_tick_cost
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.0 target/release/examples/idle_tick_cost 0
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.1 target/release/examples/idle_tick_cost 1000000
//! ```
//!
//! A second argument `deadline` adds the `Node::next_deadline` call a shell makes after each
//! poll to know when to wake up.
//!
//! (`docs/benchmarks.md`, "Idle tick").

use std::hint::black_box;

use od_core::node::{Node, Output};
use od_core::{Bitrate, Frame, Instant};
use tests_host::TableOnly;

fn main() {
    let n: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    let mut node = Node::new(TableOnly(od_core::devices::sgh10::TABLE), 1, Bitrate::K500);
    node.poll(Instant::ZERO);
    node.on_frame(&Frame::std(0, &[0x01, 0x01]), Instant::ZERO);
    // What an SDO download of 1017h = 1000 does.
    node.write(0x1017, 0, &1000u16.to_le_bytes(), Instant::ZERO).expect("valid period");
    while node.next_output().is_some_and(|o| matches!(o, Output::Frame(_))) {}
    let idle = Instant::from_micros(500);
    assert!(node.next_deadline().is_some_and(|t| t > idle), "something is due");
    if std::env::args().nth(2).as_deref() == Some("deadline") {
        // What a shell does per wake-up: poll, then ask when to wake next.
        for _ in 0..n {
            black_box(&mut node).poll(black_box(idle));
            black_box(black_box(&node).next_deadline());
        }
    } else {
        for _ in 0..n {
            black_box(&mut node).poll(black_box(idle));
        }
    }
    assert!(node.next_output().is_none());
    println!("{n} idle ticks, next deadline {:?}", node.next_deadline());
}
