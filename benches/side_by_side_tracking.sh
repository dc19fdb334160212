#!/usr/bin/env bash
# Hinted and lost-in-space core times of two builds side by side (examples/tracking part 1: 1000
# frames, 12°/512 px, hint ≤ 1° off): the two builds' binaries run in turn, ROUNDS times, each run
# timing every frame REPEAT+1 times and keeping its fastest; prints each build's median over the
# rounds of its runs' medians, and the fastest run. On a shared machine whose speed moves by a
# third between runs, alternating many short runs compares builds where one long run each cannot.
#   cargo build --release -p starid-core --example tracking   (once per commit; copy the binary)
#   bash benches/side_by_side_tracking.sh OLD_BINARY NEW_BINARY [ROUNDS=40] [REPEAT=10]
set -euo pipefail
old=$1 new=$2 rounds=${3:-40} repeat=${4:-10}
for _ in $(seq "$rounds"); do
    for b in old new; do
        bin=$old
        [ "$b" = new ] && bin=$new
        STARID_REPEAT=$repeat STARID_PART1_ONLY=1 "$bin" 1000 0 |
            sed -E "s/.*lost in space [0-9]+ identified, median ([0-9.]+) µs.*hinted.*median ([0-9.]+) µs p99.*/$b \1 \2/"
    done
done | python3 -c '
import statistics as st, sys
runs = {}
for line in sys.stdin:
    name, lis, hint = line.split()
    runs.setdefault(name, []).append((float(lis), float(hint)))
for name in ("old", "new"):
    lis = [r[0] for r in runs[name]]
    hint = [r[1] for r in runs[name]]
    print(f"{name}: hinted {st.median(hint):.3f} us (fastest run {min(hint):.2f}), lost in space "
          f"{st.median(lis):.3f} us (fastest run {min(lis):.2f}), {len(hint)} runs")
'
