//! Cost of answering an expedited SDO upload: `Node::on_frame` with a read of 1018h.01, N times.
//!
//! An SGH10 (node-ID 1, its own dictionary) in PRE-OPERATIONAL; each iteration hands the node one
//! request and takes the response, as a shell would. Run under callgrind with two values of N and
//! divide the difference by the difference of N:
//!
//! ```sh
//! cargo build --release -p tests-host --example sdo_upload_cost
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.0 target/release/examples/sdo_upload_cost 0
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.1 target/release/examples/sdo_upload_cost 1000000
//! ```
//!
//! (`docs/benchmarks.md`, "SDO expedited upload").

use std::hint::black_box;

use od_core::node::{Node, Output};
use od_core::{Bitrate, CanId, Frame, Instant};
use tests_host::TableOnly;

fn main() {
    let n: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    let mut node = Node::new(TableOnly(od_core::devices::sgh10::TABLE), 1, Bitrate::K500);
    node.poll(Instant::ZERO);
    while node.next_output().is_some() {}
    let request = Frame::std(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    let now = Instant::from_millis(1);
    let mut answered = 0u64;
    for _ in 0..n {
        black_box(&mut node).on_frame(black_box(&request), black_box(now));
        if let Some(Output::Frame(f)) = black_box(&mut node).next_output() {
            black_box(f);
            answered += 1;
        }
    }
    assert_eq!(answered, n, "one response per request");
    node.on_frame(&request, now);
    let Some(Output::Frame(f)) = node.next_output() else { panic!("no response") };
    assert_eq!((f.id, f.payload()), (CanId::Std(0x581), &[0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0, 0][..]));
    println!("{n} uploads, {answered} responses");
}
