"""Batch throughput of ``identify_many`` on the S1 frames of the peer benchmark (12 deg / 512 px,
stars to magnitude 6, 0.2 px noise, 0.1 mag noise; spots brightest first), on every core.

    python benches/bench_batch.py [--input magnitudes|order|realistic] [--frames 2000] [--runs 5]

One warm-up batch builds what the first frames need (the pair indexes, the magnitude-split
index); the figure is the median of ``--runs`` batches. Batch figures on a shared machine move by
a third between runs: to compare two builds, run this script from each build's environment in
turn, several times.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--input", choices=["magnitudes", "order", "realistic"], default="magnitudes")
    p.add_argument("--frames", type=int, default=2000)
    p.add_argument("--runs", type=int, default=5)
    args = p.parse_args()
    cat = starid.Catalog.default()
    rng = np.random.default_rng(11)
    frames = [
        starid.simulate(cat, 12.0, (512, 512), seed=s, mag_noise=0.1, mag_limit=6.0, noise_px=0.2)
        for s in range(args.frames)
    ]
    order = [np.argsort(f.magnitudes) for f in frames]
    xys = [f.xy[o] for f, o in zip(frames, order)]
    kw: dict[str, Any] = {}
    mags: Any = None
    if args.input == "magnitudes":
        mags = [f.magnitudes[o] for f, o in zip(frames, order)]
    elif args.input == "realistic":
        # 0.3 mag more scatter and a zero point the solver is not told, as the peer benchmark's.
        mags = [f.magnitudes[o] + rng.normal(0.0, 0.3, len(o)) + rng.uniform(-8.0, 8.0) for f, o in zip(frames, order)]
        kw["mag_offset"] = None
    starid.identify_many(xys, cat, fov_deg=12.0, image_size=(512, 512), magnitudes=mags, **kw)
    rates = []
    for _ in range(args.runs):
        t = time.perf_counter()
        starid.identify_many(xys, cat, fov_deg=12.0, image_size=(512, 512), magnitudes=mags, **kw)
        rates.append(len(xys) / (time.perf_counter() - t))
    print(f"S1 batch, {args.input}: {np.median(rates):.0f} frames/s (median of {args.runs}; {min(rates):.0f}-{max(rates):.0f})")


if __name__ == "__main__":
    main()
