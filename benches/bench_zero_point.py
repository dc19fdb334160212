"""A batch that learns its magnitude zero point (``learn_zero_point``), against each frame alone.

Hostile scene families (K1: 3-20 stars among 40-80 false spots; K2: narrow, about 5 false
spots), with instrument magnitudes: the simulated ones (false spots' fit their place in the
brightness order) plus one unknown zero point for the batch and 0.3 mag more scatter. Three
runs of ``identify_many`` on the same frames:

- ``alone``: ``mag_offset=None, learn_zero_point=False`` (every frame from its brightness
  order alone, as before the batch learned);
- ``learned``: ``mag_offset=None`` (the default ``learn_zero_point=True``);
- ``given``: the true zero point passed as ``mag_offset`` (the best a calibrated user gets).

Identified: the boresight within 0.1 deg of the truth; wrong ids: ids that are not the truth.

    python benches/bench_zero_point.py [--frames 300] [--families K1 K2] [--images 100]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--families", nargs="+", default=["K1", "K2"])
    p.add_argument("--zero-point", type=float, default=3.7, help="the batch's unknown zero point (mag)")
    p.add_argument("--images", type=int, default=0,
                   help="also this many simulated images (10 deg, 1024x768, 30 false spots): one by one against identify_many")
    args = p.parse_args()
    if args.images:
        sims = [
            starid.simulate_image(fov_deg=10.0, image_size=(1024, 768), seed=s, false_stars=30) for s in range(args.images)
        ]

        def right(r: Any, truth: Any) -> bool:
            return bool(r.ok and np.hypot(r.ra_deg - truth.ra_deg, r.dec_deg - truth.dec_deg) < 0.1)

        alone = [starid.identify(im, fov_deg=10.0) for im, _ in sims]
        batch = starid.identify_many([im for im, _ in sims], fov_deg=10.0)
        n = len(sims)
        print(
            f"images (10 deg, 1024x768, 30 false spots, extracted): one by one {sum(right(r, t) for r, (_, t) in zip(alone, sims))}/{n} "
            f"identified; identify_many {sum(right(r, t) for r, (_, t) in zip(batch, sims))}/{n} "
            f"({sum(r.learned_mag_offset is not None for r in batch)} with the learned zero point)"
        )
    rng = np.random.default_rng(5)
    print(f"{args.frames} frames per family, zero point {args.zero_point} mag, 0.3 mag more scatter")
    print("| family | run | identified | wrong ids / ids | wall (2 cores) | per-frame median / p99 |")
    print("|---|---|---|---|---|---|")
    for fam in args.families:
        cat = starid.Catalog.deep() if fam == "K2" else starid.Catalog.default()
        scenes = [starid.simulate_scene(fam, cat, seed=s) for s in range(args.frames)]
        mags = [f.magnitudes + args.zero_point + rng.normal(0.0, 0.3, len(f.xy)) for f in scenes]
        runs: list[tuple[str, dict[str, Any]]] = [
            ("alone", {"mag_offset": None, "learn_zero_point": False}),
            ("learned", {"mag_offset": None}),
            ("given", {"mag_offset": args.zero_point}),
        ]
        for name, kw in runs:
            t0 = time.perf_counter()
            res = starid.identify_many(
                [f.xy for f in scenes], cat, scenes[0].fov_deg, scenes[0].image_size, magnitudes=mags, **kw
            )
            wall = time.perf_counter() - t0
            # The boresight is the third row of ICRS -> camera.
            ok = sum(
                r.ok
                and float(np.degrees(np.arccos(np.clip(r.rotation_matrix[2] @ f.rotation_matrix[2], -1.0, 1.0)))) < 0.1
                for f, r in zip(scenes, res)
            )
            ids = sum(int((r.ids >= 0).sum()) for r in res)
            wrong = sum(int(((r.ids >= 0) & (r.ids != f.true_ids)).sum()) for f, r in zip(scenes, res))
            t = np.array([r.time_s for r in res]) * 1e3
            print(
                f"| {fam} | {name} | {100 * ok / len(scenes):.1f} % | {wrong} / {ids} | {wall:.1f} s | "
                f"{np.median(t):.2f} / {np.percentile(t, 99):.1f} ms |",
                flush=True,
            )


if __name__ == "__main__":
    main()
