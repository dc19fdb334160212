#!/usr/bin/env bash
# Instructions per frame (callgrind; deterministic, unlike wall time on a shared machine) of
#   - hinted identification: examples/tracking part 1 (1000 frames, 12°/512 px, hint ≤ 1° off),
#   - lost in space, S1 with magnitudes: examples/scenarios, 1000 less 500 frames,
#   - lost in space, S1 order only: the same with STARID_ORDER_ONLY=1.
# Needs valgrind. Usage: bash benches/callgrind_instructions.sh   (about 2 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_PROFILE_RELEASE_DEBUG=true CARGO_TARGET_DIR=target/callgrind
cargo build --release -q -p starid-core --example tracking --example scenarios
bin=target/callgrind/release/examples
out=$(mktemp -d)
refs() { valgrind --tool=callgrind --callgrind-out-file="$out/cg.out" --toggle-collect="$1" "${@:2}" 2>&1 \
    | awk '/refs/ {gsub(",", "", $4); print $4}'; }
lis='starid_core::identify::Solver::identify'
h=$(STARID_PART1_ONLY=1 refs '*Solver>::identify_hinted' $bin/tracking 1000 0)
m1=$(refs "$lis" $bin/scenarios 1000 1 "12deg/512px mag6 0.2px")
m0=$(refs "$lis" $bin/scenarios 500 1 "12deg/512px mag6 0.2px")
o1=$(STARID_ORDER_ONLY=1 refs "$lis" $bin/scenarios 1000 1 "12deg/512px mag6 0.2px")
o0=$(STARID_ORDER_ONLY=1 refs "$lis" $bin/scenarios 500 1 "12deg/512px mag6 0.2px")
echo "hinted (1° hint, 12°/512 px): $((h / 1000)) instructions per frame"
echo "lost in space S1, magnitudes: $(((m1 - m0) / 500)) instructions per frame"
echo "lost in space S1, order only: $(((o1 - o0) / 500)) instructions per frame"
rm -rf "$out"
