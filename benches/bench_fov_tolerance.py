"""A field of view given off: frames identified, wrong ids and time, against how far off it is.

    python benches/bench_fov_tolerance.py [--frames 200] [--offsets 0 0.02 -0.02 ...] [--tolerance 0.1]
        [--real ../shared/data/real-images] [--random 800]

Simulated: 12° frames of 512 px (0.2 px centroid noise) from the contest catalogue
(``tests/data/guide_catalog_4908.csv``), identified as one batch with the field of view given
``1 + offset`` times the truth. ``--tolerance 0`` holds the field as given (an exact field).
With ``--real``, the development frames whose pointing is known are identified too, each with
its field scaled by the same offsets, and the boresight compared with the known one. With
``--random N``, N sets of 6–24 random points per sensor (12° on 512 px, 10° on 1400 × 1000 px)
are identified with the field given, with and without magnitudes: every set named is wrong.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import starid

ROOT = Path(__file__).resolve().parent.parent


def simulated(frames: int, offsets: list[float], tolerance: float) -> None:
    cat = starid.Catalog.load(ROOT / "tests" / "data" / "guide_catalog_4908.csv")
    sims = [starid.simulate(cat, 12.0, (512, 512), seed=s, noise_px=0.2) for s in range(frames)]
    print(f"simulated: {frames} frames, 12° / 512 px, 0.2 px noise, fov_tolerance {tolerance}")
    print("| field given | identified | wrong ids (frames) | time per frame (2 threads) |")
    print("|---|---|---|---|")
    for off in offsets:
        t = time.perf_counter()
        res = starid.identify_many([f.xy for f in sims], cat, fov_deg=12.0 * (1 + off), image_size=(512, 512), fov_tolerance=tolerance)
        dt = time.perf_counter() - t
        wrong = [int(((r.ids >= 0) & (r.ids != f.true_ids)).sum()) for r, f in zip(res, sims)]
        print(f"| {off:+.0%} | {sum(r.ok for r in res)}/{frames} | {sum(wrong)} ({sum(w > 0 for w in wrong)}) | {1e3 * dt / frames:.1f} ms |")


def real(folder: Path, offsets: list[float], tolerance: float) -> None:
    truth = json.loads((folder / "truth.json").read_text())
    known = {k: v for k, v in truth.items() if "ra_deg" in v and "consensus" in v.get("truth", "")}
    print(f"\nreal frames whose pointing two solvers agree on: {len(known)}, fov_tolerance {tolerance}")
    print("| field given | identified | boresight within 60″ of the known | wrong |")
    print("|---|---|---|---|")
    for off in offsets:
        ok = right = wrong = 0
        for name, t in known.items():
            fov = t["fov_deg"] if "ost-6deg" not in name else 6.076  # the 6° camera's measured field
            r = starid.identify(folder / name, fov_deg=fov * (1 + off), fov_tolerance=tolerance)
            r = getattr(r, "identification", r)
            if not r.ok:
                continue
            ok += 1
            a = np.radians([r.ra_deg, r.dec_deg, t["ra_deg"], t["dec_deg"]])
            sep = math.degrees(math.acos(min(1.0, math.sin(a[1]) * math.sin(a[3]) + math.cos(a[1]) * math.cos(a[3]) * math.cos(a[0] - a[2]))))
            right += sep * 3600 < 60
            wrong += sep * 3600 >= 60
        print(f"| {off:+.0%} | {ok}/{len(known)} | {right} | {wrong} |")


def random_points(sets: int) -> None:
    rng = np.random.default_rng(7)
    print(f"\nrandom points: {sets} sets of 6-24 per sensor, field given, fov_tolerance default")
    print("| sensor | named without magnitudes | named with magnitudes |")
    print("|---|---|---|")
    for fov, size in [(12.0, (512, 512)), (10.0, (1400, 1000))]:
        frames, mags = [], []
        for _ in range(sets):
            n = int(rng.integers(6, 25))
            frames.append(rng.uniform([0, 0], size, (n, 2)))
            mags.append(rng.uniform(2, 7, n))
        plain = starid.identify_many(frames, fov_deg=fov, image_size=size)
        with_mags = starid.identify_many(frames, fov_deg=fov, image_size=size, magnitudes=mags)
        print(f"| {fov:g}° on {size[0]}x{size[1]} | {sum(r.ok for r in plain)}/{sets} | {sum(r.ok for r in with_mags)}/{sets} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=200)
    p.add_argument("--offsets", type=float, nargs="+", default=[0, 0.02, -0.02, 0.05, -0.05, 0.08, -0.08, 0.1, -0.1, 0.2, -0.2])
    p.add_argument("--tolerance", type=float, default=0.1)
    p.add_argument("--real", type=Path, help="the development frames' folder (with truth.json)")
    p.add_argument("--random", type=int, default=0, help="sets of random points per sensor")
    args = p.parse_args()
    if args.frames > 0:
        simulated(args.frames, args.offsets, args.tolerance)
    if args.real is not None:
        real(args.real, args.offsets, args.tolerance)
    if args.random > 0:
        random_points(args.random)


if __name__ == "__main__":
    main()
