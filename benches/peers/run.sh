#!/usr/bin/env bash
# One command: a virtual environment with starid and its peers, then the side-by-side benchmark.
#   bash benches/peers/run.sh [--frames 500] [--scenarios all] [--png peers.png]
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=.venv-peers
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --quiet --upgrade pip
"$VENV/bin/python" -m pip install --quiet . -r benches/peers/requirements.txt
# matplotlib separately: cedar-solve pins Pillow<9, which has no wheels for current Pythons;
# pip then only warns about the pin, and cedar-solve's solver does not use Pillow.
"$VENV/bin/python" -m pip install --quiet "matplotlib>=3.5" || echo "matplotlib not installed: no PNG"
"$VENV/bin/python" benches/peers/bench_peers.py "$@"
