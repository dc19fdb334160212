"""Pair-index sizes and build times: every index the solver keeps, for the bundled and the
contest catalogue at the contest cameras' geometries (the README's "Pair indexes" figures).

    python benches/bench_index.py [--repeat 3]

Each build uses a fresh copy of the catalogue (no cached index); times are the fastest of
``--repeat`` builds, sizes are exact.
"""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

import starid

CONTEST = Path(__file__).resolve().parents[1] / "tests" / "data" / "guide_catalog_4908.csv"
GEOMETRIES = [("12°/512 px", 12.0, (512, 512)), ("20°/1024 px", 20.0, (1024, 1024))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    catalogs = [("bundled (Hipparcos Hp <= 6.5)", starid.Catalog.default()), ("contest (4908)", starid.Catalog.from_csv(CONTEST))]
    print("| catalogue | frames | pairs + bright pairs | pair index | bright index | magnitude index | all | build (pairs) | build (magnitude) |")
    print("|---|---|---|---|---|---|---|---|---|")
    mb = 1e-6
    for name, cat in catalogs:
        blob = pickle.dumps(cat)
        for label, fov, size in GEOMETRIES:
            best = None
            for _ in range(args.repeat):
                fresh = pickle.loads(blob)  # no index cached on it
                info = fresh.index_info(fov, size, magnitude_index=True)
                if best is None or info["build_time_s"] < best["build_time_s"]:
                    best = info
            assert best is not None
            print(
                f"| {name} | {label} | {best['pairs']:,} + {best['bright_pairs']:,} | "
                f"{best['pair_index_bytes'] * mb:.2f} MB | {best['bright_index_bytes'] * mb:.2f} MB | "
                f"{best['magnitude_index_bytes'] * mb:.2f} MB | {best['memory_bytes'] * mb:.2f} MB | "
                f"{best['build_time_s'] * 1e3:.0f} ms | {best['magnitude_index_build_time_s'] * 1e3:.0f} ms |"
            )


if __name__ == "__main__":
    main()
