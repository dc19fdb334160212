"""The source documents' identification methods beside Pyramid and voting, raw and verified
(the README's "The source documents' methods, measured" table and ``docs/methods.png``).

    python benches/bench_methods.py [--frames 1000] [--plot docs/methods.png] [--markdown]

Contest catalogue (4908 stars), the two contest cameras (12°/512 px and 20°/1024 px), no
magnitudes (centroids in random order, as the documents had them). Every method is told the
centroid noise (``centroid_sigma_px``: the cell's noise, 0.2 px for clean frames) and is run
twice: verified (the default; every answer passes the shared verification) and raw
(``verify=False``: the method's own first answer). One run; the same frames for every method.

Per cell: frames *right* (at least one id, none wrong), *fully right* (every real star named,
none wrong), *wrong* (at least one wrong id), and the median and p99 of the core's time per
frame. Then each method's database: size and build time.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

import starid

CONTEST = Path(__file__).resolve().parents[1] / "tests" / "data" / "guide_catalog_4908.csv"
CAMERAS = [("12°/512 px", 12.0, (512, 512)), ("20°/1024 px", 20.0, (1024, 1024))]
METHODS = ["angular-distance", "star-line-angle", "angle-sum", "distance-vote", "radial-vote", "pyramid", "voting"]
# (label, simulate settings)
CELLS: list[tuple[str, dict[str, Any]]] = [
    ("clean", {}),
    ("noise 0.5 px", {"noise_px": 0.5}),
    ("noise 1 px", {"noise_px": 1.0}),
    ("noise 2 px", {"noise_px": 2.0}),
    ("10 % missing", {"drop_fraction": 0.1}),
    ("30 % missing", {"drop_fraction": 0.3}),
    ("1 false", {"false_stars": 1}),
    ("3 false", {"false_stars": 3}),
    ("10 false", {"false_stars": 10}),
]


def frames_for(cat: starid.Catalog, fov: float, size: tuple[int, int], sim: dict[str, Any], n: int, seed0: int) -> list[Any]:
    rng = np.random.default_rng(seed0)
    out = []
    for s in range(n):
        f = starid.simulate(cat, fov, size, seed=seed0 + s, **sim)
        perm = rng.permutation(len(f.xy))  # no brightness order: the documents had none
        out.append((np.ascontiguousarray(f.xy[perm]), np.asarray(f.true_ids)[perm]))
    return out


def score(frames: list[Any], results: list[Any]) -> dict[str, float]:
    right = full = wrong = 0
    times = []
    for (_, truth), r in zip(frames, results):
        ids = np.asarray(r.ids)
        w = int(((ids >= 0) & (ids != truth)).sum())
        c = int(((ids >= 0) & (ids == truth)).sum())
        wrong += w > 0
        right += w == 0 and c > 0
        full += w == 0 and c == int((truth >= 0).sum())
        times.append(r.time_s)
    t = np.asarray(times) * 1e3
    return {"right": right, "full": full, "wrong": wrong, "median_ms": float(np.median(t)), "p99_ms": float(np.percentile(t, 99))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000, help="frames per cell")
    ap.add_argument("--plot", type=Path, help="save the rate plots here (needs starid-solver[plot])")
    ap.add_argument("--markdown", action="store_true", help="print the summary table as Markdown")
    args = ap.parse_args()
    cat = starid.Catalog.from_csv(CONTEST)
    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    for cam_label, fov, size in CAMERAS:
        for k, (cell, sim) in enumerate(CELLS):
            frames = frames_for(cat, fov, size, sim, args.frames, 1_000_000 * (k + 1) + int(fov))
            xys = [f[0] for f in frames]
            sigma = max(float(sim.get("noise_px", 0.0)), 0.2)
            for method in METHODS:
                for verify in (True, False):
                    res = starid.identify_many(xys, cat, fov, size, method=method, verify=verify, centroid_sigma_px=sigma)
                    s = score(frames, res)
                    rows.append({"camera": cam_label, "cell": cell, "method": method, "verify": verify, **s})
                    print(
                        f"{cam_label:12} {cell:13} {method:17} {'verified' if verify else 'raw':8} "
                        f"right {s['right']:5} full {s['full']:5} wrong {s['wrong']:5} "
                        f"median {s['median_ms']:7.3f} ms p99 {s['p99_ms']:8.3f} ms",
                        flush=True,
                    )
    print(f"# {len(rows)} runs of {args.frames} frames in {time.perf_counter() - t0:.0f} s")
    print("\n# databases (contest catalogue)")
    for cam_label, fov, size in CAMERAS:
        for method in METHODS:
            info = cat.method_index(method, fov, size)
            print(f"{cam_label:12} {method:17} {info['bytes'] / 1e3:10.1f} kB  built in {info['build_time_s'] * 1e3:7.1f} ms")
    if args.markdown:
        markdown(rows, args.frames)
    if args.plot:
        plot(rows, args.frames, args.plot)


def markdown(rows: list[dict[str, Any]], n: int) -> None:
    """One table per camera: rows are methods (verified / raw), columns the cells; each entry
    is 'right % / wrong %' of the frames."""
    for cam_label, _, _ in CAMERAS:
        print(f"\n**{cam_label}**, {n} frames a cell: frames right / with a wrong id (%), verified · raw\n")
        print("| method | " + " | ".join(c for c, _ in CELLS) + " | median / p99 ms (clean, verified) |")
        print("|---" * (len(CELLS) + 2) + "|")
        for method in METHODS:
            cells = []
            for cell, _ in CELLS:
                v = next(r for r in rows if r["camera"] == cam_label and r["cell"] == cell and r["method"] == method and r["verify"])
                w = next(r for r in rows if r["camera"] == cam_label and r["cell"] == cell and r["method"] == method and not r["verify"])
                cells.append(f"{100 * v['right'] / n:.0f}/{100 * v['wrong'] / n:.0f} · {100 * w['right'] / n:.0f}/{100 * w['wrong'] / n:.0f}")
            c = next(r for r in rows if r["camera"] == cam_label and r["cell"] == "clean" and r["method"] == method and r["verify"])
            print(f"| {method} | " + " | ".join(cells) + f" | {c['median_ms']:.3f} / {c['p99_ms']:.3f} |")


def plot(rows: list[dict[str, Any]], n: int, path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("the plot needs matplotlib: pip install 'starid-solver[plot]'") from None
    noise = [("clean", 0.0), ("noise 0.5 px", 0.5), ("noise 1 px", 1.0), ("noise 2 px", 2.0)]
    false = [("clean", 0), ("1 false", 1), ("3 false", 3), ("10 false", 10)]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharey=True)
    for row, (cam_label, _, _) in enumerate(CAMERAS):
        for col, (axis, xs, label) in enumerate([("noise", noise, "centroid noise (px, 1σ)"), ("false", false, "false spots per frame")]):
            ax = axes[row][col]
            for k, method in enumerate(METHODS):
                for verify, style in ((True, "-"), (False, ":")):
                    ys = [
                        next(r for r in rows if r["camera"] == cam_label and r["cell"] == cell and r["method"] == method and r["verify"] == verify)["right"]
                        for cell, _ in xs
                    ]
                    ax.plot([x for _, x in xs], [100 * y / n for y in ys], style, color=f"C{k}", marker="o", ms=3,
                            label=f"{method}{'' if verify else ' (raw)'}")
            ax.set_xlabel(label)
            ax.set_title(f"{cam_label}: frames right (no wrong id) vs {axis}")
            ax.grid(alpha=0.3)
            if col == 0:
                ax.set_ylabel("% of frames")
    axes[0][1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"saved {path}")


if __name__ == "__main__":
    main()
