"""Camera calibration side by side: starid.calibrate and tetra3rs's SolverDatabase.calibrate_camera
on the same simulated frames of wide-angle lenses with known distortion.

Each lens (1280 x 1024 px, 0.2 px centroid noise, 0.1 mag noise) has radial and decentering
distortion and a principal point off the centre. Both solvers are given only the nominal field of
view; each identifies the frames with it, calibrates from its own identifications, and identifies
the frames again with the camera it found. Printed per lens and solver: frames identified before
and after, the RMS residual before and after (radial, sqrt(mean(dx² + dy²)), pixels), the focal
length's and principal point's errors against the truth, and the calibration's time.

    .venv-peers/bin/python benches/peers/bench_calibrate.py [--frames 20]

(``bash benches/peers/run.sh`` makes ``.venv-peers`` with starid and tetra3rs.)
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import starid

SIZE = (1280, 1024)
LENSES = [
    dict(fov=20.0, pp=(660.0, 512.0), k1=-0.2, k2=0.0, k3=0.0, p1=4e-4, p2=-3e-4),
    dict(fov=30.0, pp=(626.0, 526.0), k1=-0.15, k2=0.02, k3=0.0, p1=-5e-4, p2=6e-4),
    dict(fov=40.0, pp=(640.0, 492.0), k1=-0.2, k2=0.03, k3=0.0, p1=1e-3, p2=5e-4),
    dict(fov=60.0, pp=(654.0, 526.0), k1=-0.2, k2=0.04, k3=-0.005, p1=-8e-4, p2=-8e-4),
]


def frames_of(lens: dict, n: int) -> tuple[starid.Camera, starid.Camera, list]:
    truth = starid.Camera(SIZE, lens["fov"], principal_point=lens["pp"], k1=lens["k1"], k2=lens["k2"], k3=lens["k3"], p1=lens["p1"], p2=lens["p2"])
    nominal = starid.Camera(SIZE, lens["fov"])
    frames = [starid.simulate(camera=truth, noise_px=0.2, mag_noise=0.1, seed=1000 + s) for s in range(n)]
    return truth, nominal, frames


def radial_rms(cal) -> float:
    r = np.concatenate([res[m] for res, m in zip(cal.residuals_px, cal.inliers)])
    return float(np.sqrt(np.mean(np.sum(r**2, axis=1))))


def run_starid(truth, nominal, frames) -> dict:
    t = time.perf_counter()
    cal = starid.calibrate([f.xy for f in frames], camera=nominal, magnitudes=[f.magnitudes for f in frames])
    total = time.perf_counter() - t
    before, after, n = cal.identified
    cam = cal.camera
    return dict(
        before=before, after=after, rms_before=cal.rms_before_px * math.sqrt(2), rms_after=radial_rms(cal),
        f_err=100 * (cam.focal_length_px / truth.focal_length_px - 1),
        pp_err=math.dist(cam.principal_point, truth.principal_point),
        fit_s=cal.time_s, total_s=total, clipped=cal.n_clipped,
    )


def run_tetra3rs(db, tetra3rs, truth, nominal, frames, model: str, order: int) -> dict:
    w, h = SIZE
    cents = [np.column_stack([f.xy[:, 0] - w / 2, f.xy[:, 1] - h / 2, 10 ** (-0.4 * f.magnitudes)]) for f in frames]

    def solve_all(**kw):
        return [db.solve_from_centroids(c, **kw) for c in cents]

    t = time.perf_counter()
    results = solve_all(fov_estimate_deg=nominal.fov_deg, image_width=w, image_height=h)
    before = sum(getattr(r, "status", "") == "match_found" or type(r).__name__ == "SolveResult" for r in results)
    t_cal = time.perf_counter()
    cal = db.calibrate_camera(results, cents, image_width=w, image_height=h, model=model, order=order)
    fit_s = time.perf_counter() - t_cal
    again = solve_all(camera_model=cal.camera_model)
    after = sum(type(r).__name__ == "SolveResult" for r in again)
    total = time.perf_counter() - t
    cm = cal.camera_model
    cx, cy = (float(v) for v in cm.crpix)
    return dict(
        before=before, after=after, rms_before=cal.rmse_before_px, rms_after=cal.rmse_after_px,
        f_err=100 * (cm.focal_length_px / truth.focal_length_px - 1),
        pp_err=math.dist((cx + w / 2, cy + h / 2), truth.principal_point),
        fit_s=fit_s, total_s=total, clipped=cal.n_outliers,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=20)
    args = ap.parse_args()
    try:
        import tetra3rs  # type: ignore[import-not-found]
    except ImportError:
        tetra3rs = None
        print("tetra3rs not installed: starid alone")
    print(f"{args.frames} frames per lens, {SIZE[0]}x{SIZE[1]} px, 0.2 px noise; RMS radial (sqrt(mean(dx²+dy²))), pixels")
    print("| lens | solver | identified before | after | RMS before | RMS after | f error % | pp error px | clipped | fit s | total s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for lens in LENSES:
        truth, nominal, frames = frames_of(lens, args.frames)
        name = f"{lens['fov']:.0f}° k1 {lens['k1']}"
        rows = [("starid", run_starid(truth, nominal, frames))]
        if tetra3rs is not None:
            diag = truth.diagonal_fov_deg
            db = tetra3rs.SolverDatabase.generate_from_gaia(max_fov_deg=diag * 1.05, min_fov_deg=lens["fov"] * 0.9)
            for model, order in (("polynomial", 4), ("radial", 3)):
                try:
                    rows.append((f"tetra3rs {model}", run_tetra3rs(db, tetra3rs, truth, nominal, frames, model, order)))
                except Exception as e:  # a peer's failure is a row, not the end of the benchmark
                    rows.append((f"tetra3rs {model}", f"failed: {type(e).__name__}: {e}"))
        for solver, r in rows:
            if isinstance(r, str):
                print(f"| {name} | {solver} | {r} |")
                continue
            print(
                f"| {name} | {solver} | {r['before']}/{args.frames} | {r['after']}/{args.frames} | {r['rms_before']:.3f} | "
                f"{r['rms_after']:.3f} | {r['f_err']:+.4f} | {r['pp_err']:.2f} | {r['clipped']} | {r['fit_s']:.3f} | {r['total_s']:.2f} |"
            )


if __name__ == "__main__":
    main()
