#!/usr/bin/env bash
# Instructions per tracking call through Python (callgrind: unlike wall time on a shared machine,
# nearly deterministic), starid's hinted calls and tetra3rs's tracking mode on the same frames and
# hints as benches/peers/bench_tracking.py (200 frames): each solver's calls counted at two call
# counts, the difference divided by the calls between, so the interpreter's start, the frames'
# simulation, the index and tetra3rs's database cancel out. Reading the answer (ra, dec) is counted
# for both. Needs valgrind and .venv-peers (bash benches/peers/run.sh). About 4 minutes.
#   bash benches/peers/callgrind_tracking.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
py=${PYTHON:-.venv-peers/bin/python}
count() {
    RAYON_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONHASHSEED=0 valgrind --tool=callgrind \
        --callgrind-out-file=/dev/null "$py" benches/peers/bench_tracking.py --frames 200 --calls "$1" \
        --only "$2" 2>&1 | awk '/refs/ {gsub(",", "", $4); print $4}'
}
per_call() {
    local a b
    a=$(count 1200 "$1")
    b=$(count 200 "$1")
    echo $(((a - b) / 1000))
}
t3=$(per_call "tetra3rs tracking")
echo "tetra3rs tracking (strict_hint): $t3 instructions per call"
for name in "starid hinted (order)" "starid hinted (magnitudes)" "starid lost in space (magnitudes)"; do
    n=$(per_call "$name")
    echo "$name: $n instructions per call; tetra3rs / starid: $(awk -v a="$t3" -v b="$n" 'BEGIN {printf "%.1f", a / b}')×"
done
