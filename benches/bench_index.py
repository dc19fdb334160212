"""Pair-index sizes and build times: every index the solver keeps, for the bundled catalogues
and the contest catalogue at the contest cameras' and a 6° camera's geometries, with the size
of the index file kept on disk and the time to read it back (docs/performance.md).

    python benches/bench_index.py [--repeat 3] [--scaling 30000,100000,300000,1000000]

``--scaling`` times the 12° index build of random catalogues of those sizes instead (uniform
on the sky, magnitudes uniform in 0-12): near-linear growth is the target.

Each build uses a fresh copy of the catalogue (no index in memory) with no index cache
directory; each read a fresh copy reading the file the last build wrote to a temporary
directory. Times are the fastest of ``--repeat``, sizes are exact.
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile
from pathlib import Path

import starid

CONTEST = Path(__file__).resolve().parents[1] / "tests" / "data" / "guide_catalog_4908.csv"
CONTEST_GEOMETRIES = [("12°/512 px", 12.0, (512, 512)), ("20°/1024 px", 20.0, (1024, 1024))]
NARROW = [("6°/1392×1040 px", 6.0, (1392, 1040))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scaling", help="comma-separated catalogue sizes: time the build per size")
    args = ap.parse_args()
    if args.scaling:
        scaling([int(n) for n in args.scaling.split(",")], args.repeat)
        return
    catalogs = [
        ("bundled Hp <= 6.5", starid.Catalog.default(), CONTEST_GEOMETRIES),
        ("bundled Hp <= 8", starid.Catalog.deep(8.0), NARROW),
        ("bundled Hp <= 11", starid.Catalog.deep(11.0), NARROW),
        ("contest (4908)", starid.Catalog.from_csv(CONTEST), CONTEST_GEOMETRIES),
    ]
    print(
        "| catalogue | frames | pairs + bright pairs | pair index | bright index | magnitude index | all "
        "| build (pairs) | build (magnitude) | index file | read file |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    mb = 1e-6
    keep = starid.index_cache_dir()
    try:
        for name, cat, geometries in catalogs:
            blob = pickle.dumps(cat)
            for label, fov, size in geometries:
                with tempfile.TemporaryDirectory() as d:
                    best, read = None, float("inf")
                    for _ in range(args.repeat):
                        starid.set_index_cache_dir(None)
                        info = pickle.loads(blob).index_info(fov, size, magnitude_index=True)
                        if best is None or info["build_time_s"] < best["build_time_s"]:
                            best = info
                    starid.set_index_cache_dir(d)
                    path = pickle.loads(blob).index_info(fov, size)["index_file"]
                    for _ in range(args.repeat):
                        again = pickle.loads(blob).index_info(fov, size)
                        assert again["index_file"] == path
                        read = min(read, again["build_time_s"])
                    size_mb = os.path.getsize(path) * mb if path else 0.0
                assert best is not None
                print(
                    f"| {name} | {label} | {best['pairs']:,} + {best['bright_pairs']:,} | "
                    f"{best['pair_index_bytes'] * mb:.2f} MB | {best['bright_index_bytes'] * mb:.2f} MB | "
                    f"{best['magnitude_index_bytes'] * mb:.2f} MB | {best['memory_bytes'] * mb:.2f} MB | "
                    f"{best['build_time_s'] * 1e3:.0f} ms | {best['magnitude_index_build_time_s'] * 1e3:.0f} ms | "
                    + (f"{size_mb:.2f} MB | {read * 1e3:.0f} ms |" if path else "not kept (small) | |")
                )
    finally:
        starid.set_index_cache_dir(keep)


def scaling(sizes: list[int], repeat: int) -> None:
    """Build time of the 12° index against catalogue size (random catalogues)."""
    import time

    import numpy as np

    print("| stars | build | per 1 000 stars |")
    print("|---|---|---|")
    for n in sizes:
        rng = np.random.default_rng(n)
        ra, dec = rng.uniform(0, 360, n), np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
        mag = rng.uniform(0, 12, n)
        best = float("inf")
        starid.set_index_cache_dir(None)
        for _ in range(repeat):
            cat = starid.Catalog(np.arange(n), ra, dec, mag)
            t0 = time.perf_counter()
            cat.index_info(12.0, (512, 512))
            best = min(best, time.perf_counter() - t0)
        print(f"| {n:,} | {best:.2f} s | {best / n * 1e6:.2f} ms |")


if __name__ == "__main__":
    main()
