"""The hostile-field scene families through the Python API: Kelvins score and time per scene.

    python benches/bench_families.py [--scenes 1000] [--families K1 K2 K3] [--method auto]

K1 (Kelvins "Star Trackers: First Contact" style) runs on the bundled catalogue (Hp <= 6.5);
K2 and K3 need catalogues to magnitude 8 and 11 from ``Catalog.hipparcos`` (``pip install
.[hipparcos]``). Per family: the Kelvins score (sum over scenes of max((c - 2w) / max(t, 1), -1),
c right ids, w wrong ids, t real catalogued stars; scaled to 100) and its ceiling (the share of
scenes with >= 4 real stars), scenes identified, scenes with >= 4 real stars fully identified,
ids right and wrong, and the core's median and p99 time per scene. The same figures in pure Rust:
``STARID_HIP2=... cargo run --release --example families``.
"""

from __future__ import annotations

import argparse

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", type=int, default=1000)
    p.add_argument("--families", nargs="+", default=["K1", "K2", "K3"])
    p.add_argument("--method", default="auto", choices=sorted(starid.METHODS))
    args = p.parse_args()
    limits = {"K1": None, "K2": 8.0, "K3": 11.0}
    for fam in args.families:
        lim = limits[fam.upper()]
        cat = starid.Catalog.default() if lim is None else starid.Catalog.hipparcos(mag_limit=lim)
        score = 0.0
        ok = ge4 = full = right = wrong = real = 0
        times = []
        for seed in range(args.scenes):
            f = starid.simulate_scene(fam, cat, seed=seed)
            res = starid.identify(
                f.xy, catalog=cat, fov_deg=f.fov_deg, image_size=f.image_size, magnitudes=f.magnitudes, method=args.method
            )
            times.append(res.time_s)
            got = res.ids >= 0
            c = int(np.count_nonzero(got & (res.ids == f.true_ids)))
            w = int(np.count_nonzero(got & (res.ids != f.true_ids)))
            t = f.n_real
            score += max((c - 2 * w) / max(t, 1), -1.0)
            ok += res.ok
            right, wrong, real = right + c, wrong + w, real + t
            if t >= 4:
                ge4 += 1
                full += w == 0 and c == t
        ms = np.array(times) * 1e3
        print(
            f"{fam}: score {100 * score / args.scenes:.2f} (ceiling {100 * ge4 / args.scenes:.1f}), "
            f"identified {100 * ok / args.scenes:.2f} % of scenes, {100 * full / max(ge4, 1):.2f} % of scenes with >= 4 "
            f"stars fully; ids right {right}/{real} ({100 * right / max(real, 1):.2f} %), wrong {wrong}; "
            f"median {np.median(ms):.3f} ms, p99 {np.percentile(ms, 99):.2f} ms"
        )


if __name__ == "__main__":
    main()
