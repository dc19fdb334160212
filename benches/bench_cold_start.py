"""A new process solving one image: what `starid identify FILE` adds to `import starid`.

    python benches/bench_cold_start.py IMAGE [--fov-deg 6.1] [--runs 7]

Each run is a fresh interpreter, so it pays for everything a command-line user pays for but the
index build: the index files are in the cache directory already (one warm-up run writes them).
Reported: the median wall time of ``python -c "import starid"``, of ``starid identify IMAGE``
with the field given and without it, and the difference to the import, side by side in one run,
with the read / extract / identify times that the command itself prints.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

STARID = [sys.executable, "-c", "import sys; from starid.cli import main; sys.exit(main())"]


# Compiled modules, as an installed package has them: an editable install under
# PYTHONDONTWRITEBYTECODE would compile every module of starid in every run.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def wall(cmd: list[str]) -> tuple[float, str]:
    t = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=False, env=ENV)
    return time.perf_counter() - t, out.stdout


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("image", type=Path)
    p.add_argument("--fov-deg", type=float, default=None, help="the field given (default: also run without one)")
    p.add_argument("--runs", type=int, default=7)
    args = p.parse_args()
    cases = {"import starid": [sys.executable, "-c", "import starid"]}
    if args.fov_deg is not None:
        given = ["identify", str(args.image), "--fov-deg", str(args.fov_deg)]
        cases[f"identify --fov-deg {args.fov_deg:g}"] = STARID + given
    cases["identify, field unknown"] = STARID + ["identify", str(args.image)]
    for cmd in cases.values():
        wall(cmd)  # the index files, written once
    times: dict[str, list[float]] = {k: [] for k in cases}
    printed: dict[str, str] = {}
    for _ in range(args.runs):
        for k, cmd in cases.items():  # interleaved, so that the machine's drift touches each alike
            dt, out = wall(cmd)
            times[k].append(dt)
            m = re.search(r"time: (.*)", out)
            if m:
                printed[k] = m.group(1)
    base = statistics.median(times["import starid"])
    print(f"{args.image.name}, {args.runs} runs each, medians")
    print("| command | wall | added to the import | the command's own times (last run) |")
    print("|---|---|---|---|")
    for k, ts in times.items():
        med = statistics.median(ts)
        added = "" if k == "import starid" else f"{1e3 * (med - base):.0f} ms"
        print(f"| `{k}` | {1e3 * med:.0f} ms | {added} | {printed.get(k, '')} |")


if __name__ == "__main__":
    main()
