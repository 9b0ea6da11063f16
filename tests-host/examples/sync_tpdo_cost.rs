//! Cost of turning a SYNC into a 6-byte TPDO: `Node::on_frame` with a SYNC, N times.
//!
//! An SGH10 (node-ID 1, its own dictionary) in OPERATIONAL: TPDO2 (280h + 1) maps 6020h.01
//! (32 bits) and 6030h.01 (16 bits) and has transmission type 1, so every SYNC sends it. Each
//! iteration hands the node one SYNC and takes the TPDO it produced, as a shell would. Run
//! under callgrind with two values of N and divide the difference by the difference of N:
//!
//! ```sh
//! cargo build --release -p tests-host --example sync_tpdo_cost
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.0 target/release/examples/sync_tpdo_cost 0
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.1 target/release/examples/sync_tpdo_cost 1000000
//! ```
//!
//! (`docs/benchmarks.md`, "SYNC to TPDO").

use std::hint::black_box;

use od_core::node::{Node, Output};
use od_core::{Bitrate, CanId, Frame, Instant};
use tests_host::TableOnly;

fn main() {
    let n: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    let mut node = Node::new(TableOnly(od_core::devices::sgh10::TABLE), 1, Bitrate::K500);
    node.poll(Instant::ZERO);
    node.on_frame(&Frame::std(0, &[0x01, 0x01]), Instant::ZERO);
    node.split().1.od.set_value(0x6020, 1, 510);
    while node.next_output().is_some() {}
    let sync = Frame::std(0x080, &[]);
    let now = Instant::from_millis(1);
    let mut sent = 0u64;
    for _ in 0..n {
        black_box(&mut node).on_frame(black_box(&sync), black_box(now));
        if let Some(Output::Frame(f)) = black_box(&mut node).next_output() {
            black_box(f);
            sent += 1;
        }
    }
    assert_eq!(sent, n, "one TPDO per SYNC");
    node.on_frame(&sync, now);
    let Some(Output::Frame(f)) = node.next_output() else { panic!("no TPDO") };
    assert_eq!((f.id, f.payload()), (CanId::Std(0x281), &[0xFE, 0x01, 0, 0, 0, 0][..]));
    println!("{n} SYNCs, {sent} TPDOs");
}
