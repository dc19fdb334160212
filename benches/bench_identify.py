"""Identification rate, wrong ids and time per frame through the Python API.

    python benches/bench_identify.py [--catalog CAT] [--frames 10000]

Scenarios are those of the targets: 12 deg / 512 px and 20 deg / 1024 px at 0.2 px noise, and
12 deg / 512 px with 1 px noise, 2 false stars and 10 % of the stars dropped. Time per frame is
the core's own timing (single thread, index already built); batch throughput uses identify_many.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import starid

SCENARIOS = [
    ("12deg/512px 0.2px", 12.0, (512, 512), {"noise_px": 0.2}),
    ("20deg/1024px 0.2px", 20.0, (1024, 1024), {"noise_px": 0.2}),
    ("12deg/512px 1px +2 false -10%", 12.0, (512, 512), {"noise_px": 1.0, "false_stars": 2, "drop_fraction": 0.1}),
]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--catalog", help="catalogue file (default: bundled)")
    p.add_argument("--frames", type=int, default=10_000)
    args = p.parse_args()
    cat = starid.Catalog.default() if args.catalog is None else starid.Catalog.load(args.catalog)
    print(repr(cat))
    for name, fov, size, sim in SCENARIOS:
        info = cat.index_info(fov, size)
        frames = [starid.simulate(cat, fov, size, seed=s, **sim) for s in range(args.frames)]
        usable = [f for f in frames if len(f.xy) >= 4]
        t0 = time.perf_counter()
        results = starid.identify_many([f.xy for f in usable], catalog=cat, fov_deg=fov, image_size=size)
        wall = time.perf_counter() - t0
        ok = sum(r.ok for r in results)
        ge4 = [(f, r) for f, r in zip(usable, results) if f.n_real >= 4]
        ids = sum(int((r.ids >= 0).sum()) for r in results)
        wrong = sum(int(((r.ids >= 0) & (r.ids != f.true_ids)).sum()) for f, r in zip(usable, results))
        times = np.array([r.time_s for r in results]) * 1e6
        print(
            f"{name}: identified {ok}/{len(frames)} ({100 * ok / len(frames):.3f} %), "
            f"among >=4 real stars {100 * sum(r.ok for _, r in ge4) / max(1, len(ge4)):.3f} %, "
            f"wrong ids {wrong}/{ids}, median {np.median(times):.1f} us, p99 {np.percentile(times, 99):.1f} us, "
            f"batch {len(usable) / wall:.0f} frames/s; index {info['pairs']} pairs, "
            f"{info['memory_bytes'] / 1e6:.2f} MB, {info['build_time_s'] * 1e3:.1f} ms"
        )


if __name__ == "__main__":
    main()
