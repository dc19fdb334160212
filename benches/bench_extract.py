"""Centroid extraction: accuracy against the Cramér–Rao bound, false detections, speed.

    python benches/bench_extract.py [--stars 2000]

Accuracy: isolated stars (pixel-integrated Gaussian PSF σ 1.2 px, Poisson noise on star and a
200 e⁻ sky, 5 e⁻ read noise) at random sub-pixel positions and SNR from 20 to 500; the RMS
error per axis of ``extract_centroids`` against the Cramér–Rao bound computed from the Fisher
information of the same pixel model. False detections: pure-noise 1-megapixel frames at the
default threshold. Speed: a 2-megapixel 16-bit simulated sky (1600 x 1200, stars to mag 6.5,
hot pixels, gradient, trail), median of 50 runs, on one thread (a child process with
``RAYON_NUM_THREADS=1``) and on every core.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time

import numpy as np

import starid

SIG, SKY, READ = 1.2, 200.0, 5.0


def render(x: float, y: float, flux: float, rng: np.random.Generator, n: int = 32) -> tuple[np.ndarray, np.ndarray]:
    i = np.arange(n)
    erf = np.vectorize(math.erf)
    fx = 0.5 * (erf((i + 1 - x) / (SIG * math.sqrt(2))) - erf((i - x) / (SIG * math.sqrt(2))))
    fy = 0.5 * (erf((i + 1 - y) / (SIG * math.sqrt(2))) - erf((i - y) / (SIG * math.sqrt(2))))
    mu = SKY + flux * np.outer(fy, fx)
    img = rng.poisson(mu) + rng.normal(0, READ, mu.shape)
    return img.astype(np.float32), mu


def crb(x: float, y: float, flux: float, n: int = 32) -> float:
    """1σ per axis from the Fisher information of the pixel model (x and y)."""
    h = 1e-4
    _, m0 = render(x, y, flux, np.random.default_rng(0), n)
    _, mx = render(x + h, y, flux, np.random.default_rng(0), n)
    d = (mx - m0) / h
    var = m0 + READ**2
    return float(1.0 / math.sqrt(np.sum(d * d / var)))


def speed() -> float:
    """Median ms of extracting the 2-megapixel 16-bit frame."""
    img, _ = starid.simulate_image(None, 15.0, (1600, 1200), seed=2, mag_limit=6.5, hot_pixels=100, gradient_e=300.0,
                                   trail=(100, 900, 1500, 700, 400))
    img16 = np.clip(img, 0, 65535).astype(np.uint16)
    starid.extract_centroids(img16)
    times = []
    for _ in range(50):
        t = time.perf_counter()
        starid.extract_centroids(img16)
        times.append(time.perf_counter() - t)
    return float(np.median(times) * 1e3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stars", type=int, default=2000)
    ap.add_argument("--images", type=int, default=200, help="simulated images per lens, end to end")
    ap.add_argument("--speed-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.speed_only:
        print(f"{speed():.1f}")
        return
    rng = np.random.default_rng(1)
    print("| SNR | stars | found | RMS error per axis | Cramér–Rao bound | ratio |")
    print("|---|---|---|---|---|---|")
    for snr in (20, 50, 100, 500):
        # flux for the SNR: F / sqrt(F + n_eff (sky + read²)), n_eff = 4π σ² pixels.
        n_eff = 4 * math.pi * SIG**2
        b = n_eff * (SKY + READ**2)
        flux = 0.5 * (snr**2 + math.sqrt(snr**4 + 4 * snr**2 * b))
        errs, bound, found = [], [], 0
        for _ in range(args.stars // 4):
            x, y = 12 + 8 * rng.random(), 12 + 8 * rng.random()
            img, _ = render(x, y, flux, rng)
            c = starid.extract_centroids(img)
            if len(c):
                k = int(np.argmin(np.hypot(c.xy[:, 0] - x, c.xy[:, 1] - y)))
                if math.hypot(c.xy[k, 0] - x, c.xy[k, 1] - y) < 2:
                    found += 1
                    errs.extend([c.xy[k, 0] - x, c.xy[k, 1] - y])
            bound.append(crb(x, y, flux))
        rms = float(np.sqrt(np.mean(np.square(errs))))
        b0 = float(np.mean(bound))
        print(f"| {snr} | {args.stars // 4} | {found} | {rms:.4f} px | {b0:.4f} px | {rms / b0:.2f} |")
    false = sum(len(starid.extract_centroids(rng.normal(SKY, math.sqrt(SKY + READ**2), (1000, 1000)).astype(np.float32))) for _ in range(10))
    print(f"false detections on pure noise: {false / 10:.1f} per megapixel (10 frames of 1 Mpx, threshold 5 sigma)")
    one = subprocess.run([sys.executable, __file__, "--speed-only"], env=dict(os.environ, RAYON_NUM_THREADS="1"),
                         check=True, capture_output=True, text=True).stdout.strip()
    print(f"2-megapixel 16-bit frame: median {one} ms per extraction on one thread, {speed():.1f} ms on every core")
    # End to end on simulated images: extract, then identify (field of view given).
    cat = starid.Catalog.default()
    print("| lens | images | identified | wrong attitudes | median end to end | p99 |")
    print("|---|---|---|---|---|---|")
    for fov, size in ((12.0, (1600, 1200)), (20.0, (1024, 1024))):
        ok = wrong = 0
        t_all = []
        for seed in range(args.images):
            r = np.random.default_rng(seed)
            x0, y0 = r.random() * size[0], r.random() * size[1]
            img, truth = starid.simulate_image(
                cat, fov, size, seed=seed, mag_limit=6.5, hot_pixels=100, gradient_e=300.0,
                trail=(x0, y0, r.random() * size[0], r.random() * size[1], 400.0),
            )
            img16 = np.clip(img, 0, 65535).astype(np.uint16)
            t = time.perf_counter()
            res = starid.identify_image(img16, cat, fov).identification
            t_all.append(time.perf_counter() - t)
            if res.ok:
                c = math.cos(math.radians(res.dec_deg)) * math.cos(math.radians(truth.dec_deg)) * math.cos(
                    math.radians(res.ra_deg - truth.ra_deg)) + math.sin(math.radians(res.dec_deg)) * math.sin(math.radians(truth.dec_deg))
                if math.degrees(math.acos(min(1.0, c))) < 0.1:
                    ok += 1
                else:
                    wrong += 1
        print(f"| {fov:g}°, {size[0]}x{size[1]} px, stars to 6.5, 100 hot pixels, gradient, trail | {args.images} | "
              f"{100 * ok / args.images:.1f} % | {wrong} | {np.median(t_all) * 1e3:.1f} ms | {np.percentile(t_all, 99) * 1e3:.1f} ms |")


if __name__ == "__main__":
    main()
