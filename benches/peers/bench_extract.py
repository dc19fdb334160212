"""Centroid extraction, starid against tetra3rs's ``extract_centroids``: the same simulated
16-bit frames, one run, single-threaded and on every core (the README's extractor comparison).

    .venv-peers/bin/python benches/peers/bench_extract.py [--frames 40]

(``bash benches/peers/run.sh`` builds ``.venv-peers``.) Frames: 1600 x 1200 px (2 megapixels),
15°, stars to magnitude 6.5 rendered by ``starid.simulate_image`` with a 1.2 px Gaussian PSF,
100 hot pixels, a gradient and a satellite trail, quantised to uint16. Both extractors get the
uint16 array at their default settings (5 σ threshold); tetra3rs with ``threads=1`` and
``threads=None``, starid in a child process with ``RAYON_NUM_THREADS=1`` and in this one.

Accuracy against the truth: a true star counts as found when a spot lies within 1.5 px; the
RMS error per axis is over stars isolated by 8 px from any other, off the trail and 4 px from
the border, found by both extractors (the same stars for both); spurious spots are those more
than 3 px from every true star and 6 px from the trail.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from typing import Any

import numpy as np

import starid

TRAIL = (100.0, 900.0, 1500.0, 700.0, 400.0)
SIZE = (1600, 1200)


def frames(n: int) -> list[tuple[Any, Any]]:
    out = []
    for seed in range(n):
        img, truth = starid.simulate_image(None, 15.0, SIZE, seed=seed, mag_limit=6.5, hot_pixels=100, gradient_e=300.0, trail=TRAIL)
        out.append((np.clip(img, 0, 65535).astype(np.uint16), truth))
    return out


def trail_distance(p: Any) -> Any:
    ax, ay, bx, by, _ = TRAIL
    t = np.clip(((p[:, 0] - ax) * (bx - ax) + (p[:, 1] - ay) * (by - ay)) / ((bx - ax) ** 2 + (by - ay) ** 2), 0, 1)
    return np.hypot(p[:, 0] - ax - t * (bx - ax), p[:, 1] - ay - t * (by - ay))


def run_starid(imgs: list[Any]) -> tuple[list[Any], list[float]]:
    starid.extract_centroids(imgs[0])
    xys, times = [], []
    for img in imgs:
        t = time.perf_counter()
        c = starid.extract_centroids(img)
        times.append(time.perf_counter() - t)
        xys.append(c.xy)
    return xys, times


def run_tetra3rs(imgs: list[Any], threads: Any) -> tuple[list[Any], list[float]]:
    import tetra3rs

    tetra3rs.extract_centroids(imgs[0], threads=threads)
    xys, times = [], []
    for img in imgs:
        t = time.perf_counter()
        r = tetra3rs.extract_centroids(img, threads=threads)
        times.append(time.perf_counter() - t)
        # tetra3rs measures from the image centre (x right, y down): starid's pixels less (W/2, H/2).
        xy = np.array([[c.x, c.y] for c in r.centroids], dtype=np.float64).reshape(-1, 2)
        xys.append(xy + np.array([SIZE[0] / 2, SIZE[1] / 2]))
    return xys, times


def accuracy(truths: list[Any], results: dict[str, list[Any]]) -> dict[str, dict[str, float]]:
    """Found, spurious and RMS error over the isolated stars every extractor found."""
    stats: dict[str, dict[str, float]] = {k: {"found": 0, "spurious": 0, "stars": 0} for k in results}
    errs: dict[str, list[float]] = {k: [] for k in results}
    for f, truth in enumerate(truths):
        true_xy = np.asarray(truth.xy)
        real = np.asarray(truth.true_ids) >= 0
        true_xy = true_xy[real]
        d_all = np.hypot(true_xy[:, None, 0] - true_xy[None, :, 0], true_xy[:, None, 1] - true_xy[None, :, 1])
        np.fill_diagonal(d_all, np.inf)
        w, h = SIZE
        isolated = (d_all.min(axis=1) > 8) & (trail_distance(true_xy) > 6) & (true_xy[:, 0] > 4) & (true_xy[:, 1] > 4) & (true_xy[:, 0] < w - 4) & (true_xy[:, 1] < h - 4)
        nearest: dict[str, Any] = {}
        for name, xys in results.items():
            xy = xys[f]
            stats[name]["stars"] += len(true_xy)
            if len(xy) == 0:
                nearest[name] = (np.full(len(true_xy), np.inf), np.zeros((len(true_xy), 2)))
                continue
            d = np.hypot(true_xy[:, None, 0] - xy[None, :, 0], true_xy[:, None, 1] - xy[None, :, 1])
            k = d.argmin(axis=1)
            nearest[name] = (d[np.arange(len(true_xy)), k], xy[k] - true_xy)
            stats[name]["found"] += int((nearest[name][0] < 1.5).sum())
            spur = (d.min(axis=0) > 3) & (trail_distance(xy) > 6)
            stats[name]["spurious"] += int(spur.sum())
        both = isolated.copy()
        for name in results:
            both &= nearest[name][0] < 1.5
        for name in results:
            errs[name].extend(nearest[name][1][both].ravel().tolist())
    for name in results:
        stats[name]["rms_px"] = float(np.sqrt(np.mean(np.square(errs[name])))) if errs[name] else float("nan")
        stats[name]["compared"] = len(errs[name]) // 2
    return stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    data = frames(args.frames)
    imgs = [d[0] for d in data]
    if args.child:  # single-threaded starid (RAYON_NUM_THREADS=1 set by the parent)
        xys, times = run_starid(imgs)
        json.dump({"xy": [x.tolist() for x in xys], "times": times}, sys.stdout)
        return
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    child = subprocess.run([sys.executable, __file__, "--frames", str(args.frames), "--child"], env=env, check=True, capture_output=True, text=True)
    one = json.loads(child.stdout)
    results: dict[str, list[Any]] = {}
    times: dict[str, list[float]] = {}
    results["starid, 1 thread"] = [np.asarray(x, dtype=np.float64).reshape(-1, 2) for x in one["xy"]]
    times["starid, 1 thread"] = one["times"]
    results["tetra3rs, 1 thread"], times["tetra3rs, 1 thread"] = run_tetra3rs(imgs, 1)
    results["starid, all cores"], times["starid, all cores"] = run_starid(imgs)
    results["tetra3rs, all cores"], times["tetra3rs, all cores"] = run_tetra3rs(imgs, None)
    stats = accuracy([d[1] for d in data], results)
    print(f"{args.frames} frames of {SIZE[0]}x{SIZE[1]} px uint16 (2 megapixels), same frames, one run")
    print("| extractor | median | p99 | stars found | spurious spots | RMS error per axis (isolated stars both found) |")
    print("|---|---|---|---|---|---|")
    for k in results:
        t = np.asarray(times[k]) * 1e3
        s = stats[k]
        print(
            f"| {k} | {np.median(t):.1f} ms | {np.percentile(t, 99):.1f} ms | {s['found'] / s['stars'] * 100:.1f} % "
            f"({int(s['found'])} / {int(s['stars'])}) | {int(s['spurious'])} | {s['rms_px']:.3f} px ({int(s['compared'])} stars)"
            + " |"
        )
    for threads in ("1 thread", "all cores"):
        ratio = np.median(times[f"tetra3rs, {threads}"]) / np.median(times[f"starid, {threads}"])
        print(f"starid is {ratio:.1f}x faster than tetra3rs ({threads})")


if __name__ == "__main__":
    main()
