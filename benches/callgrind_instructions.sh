#!/usr/bin/env bash
# Instructions per frame (callgrind; unlike wall time on a shared machine, nearly deterministic) of
#   - hinted identification: examples/tracking part 1 (1000 frames, 12°/512 px, hint ≤ 1° off),
#   - lost in space, S1 with magnitudes: examples/scenarios, frames 500 to 1500,
#   - lost in space, S1 order only: the same with STARID_ORDER_ONLY=1,
#   - lost in space, S1 and S2 with realistic magnitudes (0.3 mag more scatter, an unknown zero
#     point: STARID_REALISTIC=1),
#   - one starid.identify call from Python around a frame the core returns at once
#     (benches/call_overhead.py: the call's own cost), with the PYTHON that has starid installed
#     (default .venv/bin/python; skipped where it cannot import starid).
# Needs valgrind. Usage: bash benches/callgrind_instructions.sh   (about 3 minutes)
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
# Instructions per frame of scenario $1 with the environment settings that follow: 1500 frames
# less 500, so that what is paid once (the magnitude-split index, built by the first frame that
# needs it) cancels out. Its heap layout varies from run to run: about ±0.3k per frame.
per_frame() {
    local sc=$1 a b
    shift
    a=$([ $# -eq 0 ] || export "$@"; refs "$lis" $bin/scenarios 1500 1 "$sc")
    b=$([ $# -eq 0 ] || export "$@"; refs "$lis" $bin/scenarios 500 1 "$sc")
    echo $(((a - b) / 1000))
}
s1="12deg/512px mag6 0.2px"
s2="20deg/1024px mag6 0.2px"
echo "hinted (1° hint, 12°/512 px): $((h / 1000)) instructions per frame"
echo "lost in space S1, magnitudes: $(per_frame "$s1") instructions per frame"
echo "lost in space S1, order only: $(per_frame "$s1" STARID_ORDER_ONLY=1) instructions per frame"
echo "lost in space S1, realistic magnitudes: $(per_frame "$s1" STARID_REALISTIC=1) instructions per frame"
echo "lost in space S2, realistic magnitudes: $(per_frame "$s2" STARID_REALISTIC=1) instructions per frame"
py=${PYTHON:-.venv/bin/python}
if "$py" -c "import starid" 2>/dev/null; then
    # 11 000 calls less 1 000: the interpreter's start and the index build cancel out.
    call() {
        RAYON_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONHASHSEED=0 valgrind --tool=callgrind \
            --callgrind-out-file="$out/py.out" "$py" benches/call_overhead.py --calls "$1" --form "$2" 2>&1 \
            | awk '/refs/ {gsub(",", "", $4); print $4}'
    }
    for form in plain unknown-zero-point hinted; do
        a=$(call 11000 $form)
        b=$(call 1000 $form)
        echo "identify() call from Python ($form): $(((a - b) / 10000)) instructions per call"
    done
else
    echo "$py cannot import starid: the Python call rows are skipped"
fi
rm -rf "$out"
