#!/usr/bin/env bash
# Runs every cargo-fuzz target for a bounded time and prints the executions each made.
#
#   bash fuzz/run.sh                 # every target, FUZZ_SECONDS (60) each
#   FUZZ_SECONDS=10 bash fuzz/run.sh frames_sgh10 storage_loader
#
# cargo-fuzz needs nightly: it is installed here (`rustup toolchain install nightly --profile
# minimal`) and used only through `+nightly`; the stable toolchain rust-toolchain.toml pins is
# left alone. The corpus grows in fuzz/corpus/<target> (not committed); a crash lands in
# fuzz/artifacts/<target>: keep its input as a regression test in tests-host/tests/fuzz_props.rs.
set -euo pipefail
cd "$(dirname "$0")"

SECONDS_EACH="${FUZZ_SECONDS:-60}"
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo +nightly install cargo-fuzz --locked

TARGETS=("$@")
if [ ${#TARGETS[@]} -eq 0 ]; then
    mapfile -t TARGETS < <(cargo +nightly fuzz list)
fi

status=0
for t in "${TARGETS[@]}"; do
    mkdir -p "corpus/$t"
    log="$(mktemp)"
    if cargo +nightly fuzz run --release "$t" "corpus/$t" -- -max_total_time="$SECONDS_EACH" -max_len=4096 \
        -print_final_stats=1 >"$log" 2>&1; then
        result=ok
    else
        result=CRASH
        status=1
        grep -E 'panicked|ERROR|SUMMARY|Test unit written' "$log" | head -20 || true
    fi
    execs="$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}' | tail -1)"
    printf '%-24s %-6s %8s s %12s executions\n' "$t" "$result" "$SECONDS_EACH" "${execs:-?}"
    rm -f "$log"
done
exit $status
