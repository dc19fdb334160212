"""Pointing and focal length, measured against their targets.

    python benches/bench_pointing.py [--trials 2000] [--frames 1000] [--catalog CAT]

1. Exact data: boresight error and relative focal error of the three-star distance solution
   (known and unknown focal length) over random well-spread configurations on random skies.
2. Monte Carlo at 0.1 px on 12 deg / 512 px: sample scatter / predicted 1 sigma.
3. Levenberg-Marquardt refinement from a field-of-view guess 40 % too small or too large
   (all stars of simulated 12 deg frames): convergence rate and final errors.
4. Unknown field of view: frames with a field drawn uniformly in 8-25 deg (1024 px, 0.2 px noise),
   identified with only that range known: identified rate, wrong ids, focal error, time.
5. Time per call of the distance solver (known / unknown f) and of the refinement.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import starid
import starid.pointing as sp
from _common import angle_rad, catalog_arg

ARCSEC = math.radians(1 / 3600)


def sky(off: np.ndarray, f: float, rot: np.ndarray) -> np.ndarray:
    rays = np.column_stack([off, np.full(len(off), f)])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    v = rays @ rot
    return np.column_stack([np.degrees(np.arctan2(v[:, 1], v[:, 0])) % 360, np.degrees(np.arcsin(np.clip(v[:, 2], -1, 1)))])


def exact(trials: int, rng: np.random.Generator) -> None:
    f = starid.Camera((512, 512), 12.0).focal_length_px
    worst = {"known": 0.0, "unknown": 0.0, "focal": 0.0}
    times = {"known": [], "unknown": []}
    found = 0
    for t in range(trials):
        frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=t)
        az = rng.uniform(0, 2 * np.pi) + np.array([0, 2.1, 4.2]) + rng.uniform(-0.4, 0.4, 3)
        rad = rng.uniform(60, 250, 3)
        off = np.column_stack([rad * np.cos(az), rad * np.sin(az)])
        radec = sky(off, f, frame.rotation_matrix)
        t0 = time.perf_counter()
        known = sp.boresight_from_distances(radec, rad, focal_px=f)
        times["known"].append(time.perf_counter() - t0)
        worst["known"] = max(worst["known"], angle_rad(known[0].ra_deg, known[0].dec_deg, frame.ra_deg, frame.dec_deg))
        t0 = time.perf_counter()
        sols = sp.boresight_from_distances(radec, rad)
        times["unknown"].append(time.perf_counter() - t0)
        errs = [(angle_rad(s.ra_deg, s.dec_deg, frame.ra_deg, frame.dec_deg), abs(s.focal_px / f - 1)) for s in sols]
        e, fe = min(errs)
        if e < 0.01 * ARCSEC:
            found += 1
        worst["unknown"] = max(worst["unknown"], e)
        worst["focal"] = max(worst["focal"], fe)
    print(
        f"exact data, {trials} configurations: known f: worst boresight error {worst['known'] / ARCSEC:.2e} arcsec; "
        f"unknown f: true solution found in {found}/{trials}, worst {worst['unknown'] / ARCSEC:.2e} arcsec, "
        f"worst relative focal error {worst['focal']:.1e}"
    )
    print(
        f"  time per call: known f median {np.median(times['known']) * 1e6:.0f} us, "
        f"unknown f median {np.median(times['unknown']) * 1e3:.2f} ms"
    )


def monte_carlo() -> None:
    for name, xy in (("spread edge stars", [[486, 276], [141, 455], [136, 61]]), ("general", [[400, 300], [200, 420], [180, 90]])):
        for fit_focal in (False, True):
            mc = sp.monte_carlo(xy, (512, 512), fov_deg=12, sigma_px=0.1, fit_focal=fit_focal, trials=4000, seed=1)
            pred = math.sqrt(mc["predicted"][0, 0] + mc["predicted"][1, 1]) / ARCSEC
            print(
                f"Monte Carlo 0.1 px, {name}, {'unknown' if fit_focal else 'known'} f: predicted 1 sigma {pred:.2f} arcsec, "
                f"sample/predicted {mc['ratio']:.3f}, outliers {mc['outliers']}/4000"
            )


def refinement(cat: starid.Catalog, frames: int) -> None:
    f = starid.Camera((512, 512), 12.0).focal_length_px
    row_of = {int(i): k for k, i in enumerate(cat.ids)}
    for wrong in (0.6, 1.4):
        ok = 0
        worst_f = 0.0
        times = []
        for s in range(frames):
            fr = starid.simulate(cat, 12.0, (512, 512), seed=s, noise_px=0.0)
            real = fr.true_ids >= 0
            if real.sum() < 3:
                continue
            rows = [row_of[int(i)] for i in fr.true_ids[real]]
            radec = np.column_stack([cat.ra_deg[rows], cat.dec_deg[rows]])
            t0 = time.perf_counter()
            fit = sp.fit_pointing(radec, fr.xy[real], (512, 512), fov_deg=12.0 * wrong)
            times.append(time.perf_counter() - t0)
            err = abs(fit.focal_px / f - 1)
            if fit.converged and err < 1e-9:
                ok += 1
            worst_f = max(worst_f, err)
        print(
            f"refinement from a {wrong:.1f}x field-of-view guess: converged to f within 1e-9 in {ok}/{len(times)} frames, "
            f"worst relative focal error {worst_f:.1e}, median {np.median(times) * 1e6:.0f} us per fit"
        )


def unknown_fov(cat: starid.Catalog, frames: int) -> None:
    rng = np.random.default_rng(7)
    ok = ge4 = ok4 = wrong = ids = 0
    ferr = []
    times = []
    t_all = time.perf_counter()
    cat.index_info(25.0, (1024, 1024))
    for s in range(frames):
        fov = float(rng.uniform(8, 25))
        fr = starid.simulate(cat, fov, (1024, 1024), seed=s, noise_px=0.2, mirrored=s % 2 == 1)
        if len(fr.xy) < 4:
            continue
        ge4 += fr.n_real >= 4
        res = starid.identify(fr.xy, cat, image_size=(1024, 1024), fov_range_deg=(8.0, 25.0))
        times.append(res.time_s)
        if res.ok:
            ok += 1
            ok4 += fr.n_real >= 4
            ids += int((res.ids >= 0).sum())
            wrong += int(((res.ids >= 0) & (res.ids != fr.true_ids)).sum())
            ferr.append(abs(res.focal_px / starid.Camera((1024, 1024), fov).focal_length_px - 1))
    ferr_a = np.array(ferr)
    print(
        f"unknown FOV 8-25 deg, 1024 px, 0.2 px, {frames} frames ({cat!r}): identified {100 * ok / frames:.2f} % "
        f"({100 * ok4 / max(ge4, 1):.2f} % of frames with >= 4 stars), wrong ids {wrong}/{ids}, focal error median "
        f"{np.median(ferr_a):.1e} max {ferr_a.max():.1e} (within 0.1 %: {100 * np.mean(ferr_a < 1e-3):.2f} %), "
        f"time median {np.median(times) * 1e3:.1f} ms p99 {np.percentile(times, 99) * 1e3:.0f} ms; "
        f"wall {time.perf_counter() - t_all:.0f} s"
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trials", type=int, default=2000)
    p.add_argument("--frames", type=int, default=1000)
    p.add_argument("--catalog", help="catalogue for sections 3-4 (default: contest catalogue if present, else bundled)")
    args = p.parse_args()
    rng = np.random.default_rng(0)
    exact(args.trials, rng)
    monte_carlo()
    cat = catalog_arg(args.catalog)
    refinement(cat, min(args.frames, 500))
    unknown_fov(cat, args.frames)
    if cat.name != "default":
        unknown_fov(starid.Catalog.default(), args.frames)


if __name__ == "__main__":
    main()
