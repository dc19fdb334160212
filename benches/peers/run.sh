#!/usr/bin/env bash
# One command: a virtual environment with starid and its peers, then the side-by-side benchmark.
#   bash benches/peers/run.sh [--frames 500] [--scenarios all]
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=.venv-peers
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --quiet --upgrade pip
"$VENV/bin/python" -m pip install --quiet . -r benches/peers/requirements.txt
"$VENV/bin/python" benches/peers/bench_peers.py "$@"
