#!/usr/bin/env bash
# One command: virtual environments with starid and its peers, then the side-by-side benchmark.
#   bash benches/peers/run.sh [--frames 500] [--scenarios all] [--png docs/peers.png]
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=.venv-peers
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --quiet --upgrade pip
# cedar-solve pins Pillow<9, which starid's image reading outgrew (and which has no wheels for
# current Pythons): it goes in without its pins, and its solver's own needs after it.
grep -v cedar-solve benches/peers/requirements.txt > "$VENV/requirements-no-cedar.txt"
"$VENV/bin/python" -m pip install --quiet . -r "$VENV/requirements-no-cedar.txt"
"$VENV/bin/python" -m pip install --quiet --no-deps "$(grep cedar-solve benches/peers/requirements.txt)"
"$VENV/bin/python" -m pip install --quiet scipy
# matplotlib for the PNG.
"$VENV/bin/python" -m pip install --quiet "matplotlib>=3.5" || echo "matplotlib not installed: no PNG"
# ruststartracker needs numpy<2: its own environment, driven by benches/peers/rst_worker.py.
python3 -m venv .venv-rst
.venv-rst/bin/python -m pip install --quiet --upgrade pip
.venv-rst/bin/python -m pip install --quiet ruststartracker "numpy<2" typing_extensions scipy \
  || echo "ruststartracker could not be installed: skipped"
"$VENV/bin/python" benches/peers/bench_peers.py --rst-python .venv-rst/bin/python "$@"
