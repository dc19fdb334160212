"""Frames of a lens with radial distortion ``k1`` identified by a solver told an ideal camera.

The focal check (``focal_check``, on by default) fits the solution's pixel residuals by a scale
and a radial term and searches again with the camera they imply; ``focal_check=False`` holds the
ideal camera, and "known" gives the solver the true ``k1``. Mag 6, 0.2 px, magnitudes. Then the
field of view unknown too (``fov_range_deg``), against an ideal lens.

    python benches/bench_distortion.py [--frames 200]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=200)
    args = p.parse_args()
    cat = starid.Catalog.default()
    print(f"{args.frames} frames per case; stars named of the real ones, wrong ids, median time per frame")
    print("| camera | k1 | told ideal, focal_check=False | told ideal (default) | told the true k1 |")
    print("|---|---|---|---|---|")
    for fov, size in ((20.0, 1024), (12.0, 512)):
        for k1 in (-0.05, -0.2, -0.5, 0.2):
            frames = [
                starid.simulate(cat, fov, (size, size), seed=s, mag_noise=0.1, mag_limit=6.0, noise_px=0.2, radial_k1=k1)
                for s in range(args.frames)
            ]
            cells = []
            for cam, kw in (
                (starid.Camera((size, size), fov), {"focal_check": False}),
                (starid.Camera((size, size), fov), {}),
                (starid.Camera((size, size), fov, k1=k1), {}),
            ):
                right = wrong = total = 0
                times = []
                for f in frames:
                    t0 = time.perf_counter()
                    r = starid.identify(f.xy, cat, camera=cam, magnitudes=f.magnitudes, **kw)
                    times.append(time.perf_counter() - t0)
                    k = r.ids >= 0
                    right += int((r.ids[k] == f.true_ids[k]).sum())
                    wrong += int((r.ids[k] != f.true_ids[k]).sum())
                    total += int((f.true_ids >= 0).sum())
                cells.append(f"{100 * right / total:.1f} %, {wrong} wrong, {np.median(times) * 1e3:.2f} ms")
            print(f"| {fov:g}°/{size} px | {k1:+g} | " + " | ".join(cells) + " |", flush=True)
    # The field of view unknown too (searched in 15-25 deg).
    print()
    print("| 20°/1024 px, field of view searched in 15–25° | k1 | stars named | wrong ids | k1 found (median) | field of view error, max |")
    print("|---|---|---|---|---|---|")
    for k1 in (0.0, -0.2, 0.2):
        right = wrong = total = 0
        found, fov_err = [], []
        for s in range(args.frames):
            f = starid.simulate(cat, 20.0, (1024, 1024), seed=s, mag_noise=0.1, mag_limit=6.0, noise_px=0.2, radial_k1=k1)
            r = starid.identify(f.xy, cat, image_size=(1024, 1024), fov_range_deg=(15.0, 25.0), magnitudes=f.magnitudes)
            k = r.ids >= 0
            right += int((r.ids[k] == f.true_ids[k]).sum())
            wrong += int((r.ids[k] != f.true_ids[k]).sum())
            total += int((f.true_ids >= 0).sum())
            if r.ok:
                fov_err.append(abs(r.fov_deg - 20.0))
                if r.k1 != 0.0:
                    found.append(r.k1)
        med = f" ({np.median(found):+.3f})" if found else ""
        print(
            f"| | {k1:+g} | {100 * right / total:.1f} % | {wrong} | {len(found)} of {args.frames}{med} | "
            f"{max(fov_err):.3f}° |",
            flush=True,
        )


if __name__ == "__main__":
    main()
