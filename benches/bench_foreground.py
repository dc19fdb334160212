"""Photographs with a lit foreground (branches, a roof) across part of the field.

    python benches/bench_foreground.py [--frames 20] [--shares 0 0.3 0.5]

8-bit 10° frames of 1024 x 768 px (stars to magnitude 7.5 from the deep bundled catalogue, a
town-lit sky), the right ``share`` of the width covered by a lit, textured foreground with a
ragged edge (``simulate_image(foreground=share)``), which hides the stars behind it and makes
hundreds of spots that are not stars. Each frame's spots are extracted as ``identify(image)``
extracts them (spots on a cluttered background flagged and left out) and with every spot kept
(``drop_flagged=False``), then identified with the field of view exact, given 7 % wide, and
unknown (the catalogue starid chooses). Prints the spots per frame, the frames identified and
the wrong ids (a named spot not within 2 px of the true star of that id).
"""

from __future__ import annotations

import argparse

import numpy as np

import starid

FOV, SIZE = 10.0, (1024, 768)


def wrong_ids(r: starid.Identification, c: starid.Centroids, truth: starid.Frame) -> int:
    wrong = 0
    for (x, y), cid in zip(c.xy[r.ids >= 0], r.ids[r.ids >= 0]):
        d = np.hypot(truth.xy[:, 0] - x, truth.xy[:, 1] - y)
        k = int(d.argmin())
        wrong += int(d[k] > 2.0 or truth.true_ids[k] != cid)
    return wrong


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--shares", type=float, nargs="+", default=[0.0, 0.3, 0.5])
    args = p.parse_args()
    cat = starid.Catalog.deep(8)
    modes = {"exact": {"fov_deg": FOV}, "7 % wide": {"fov_deg": FOV * 1.07}, "unknown": {}}
    print(f"{args.frames} frames per row")
    print("| foreground | spots | spots per frame | " + " | ".join(modes) + " | wrong ids |")
    print("|---|---|---|" + "---|" * len(modes) + "---|")
    for share in args.shares:
        for drop in (True, False):
            spots, solved, wrong = [], dict.fromkeys(modes, 0), 0
            for seed in range(args.frames):
                img, truth = starid.simulate_image(
                    cat, FOV, SIZE, seed=seed, mag_limit=7.5, foreground=share, bits=8, gain_e_per_dn=8.0,
                    background_e=300.0, zero_point_e=2e7,
                )
                c = starid.extract_centroids(img, drop_flagged=drop)
                spots.append(len(c))
                for mode, kw in modes.items():
                    r = starid.identify(c, image_size=SIZE, **kw)
                    solved[mode] += int(r.ok)
                    wrong += wrong_ids(r, c, truth)
            kept = "cluttered left out" if drop else "all kept"
            cells = " | ".join(f"{solved[m]}/{args.frames}" for m in modes)
            print(f"| {share:.0%} | {kept} | {np.median(spots):.0f} | {cells} | {wrong} |")


if __name__ == "__main__":
    main()
