"""starid, tetra3rs and cedar-solve on the same real image files, file in and attitude out.

    .venv-peers/bin/python benches/peers/bench_real_images.py ../shared/data/real-images [--rounds 3]

For each image of a folder with a ``truth.json`` (the field of view as the folder states it,
and the boresight where it is known), each solver reads the file, finds its own spots and
solves, as a user would call it:

- starid: ``starid.identify(path, fov_deg=...)`` (the field an estimate, ``fov_tolerance`` 0.1
  by default) and ``starid.identify(path)`` (the field unknown); and the same from the decoded
  array (``starid.read_image``), so that the decode's share shows.
- tetra3rs: Pillow decodes the file to 8- or 16-bit grey, ``tetra3rs.extract_centroids`` finds
  the spots, ``SolverDatabase.solve_from_centroids`` solves with ``fov_max_error`` 10 % of the
  field. Its database (``generate_from_gaia`` for 0.9-1.1 times the field, once per field, not
  timed) stays in memory.
- cedar-solve (import name ``tetra3``): ``Tetra3.solve_from_image`` on the Pillow image with
  ``fov_max_error`` 10 %, its shipped default database.

Each call runs ``--rounds`` times in turn and keeps its fastest: the warm time, decode included
where the solver reads the file. A solution counts as right within 0.1° of the known boresight;
where none is known, every solution is shown, for agreement to tell. Prints one Markdown table.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np
from PIL import Image

import starid

Solution = Optional[tuple[float, float]]


def separation_deg(a: tuple[float, float], b: tuple[float, float]) -> float:
    ra1, d1, ra2, d2 = np.radians([a[0], a[1], b[0], b[1]])
    c = math.sin(d1) * math.sin(d2) + math.cos(d1) * math.cos(d2) * math.cos(ra1 - ra2)
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))


def grey(path: Path) -> np.ndarray:
    """The file as one grey channel, 16-bit kept as 16-bit (what tetra3rs takes)."""
    with Image.open(path) as im:
        if im.mode in ("I;16", "I;16B", "I"):
            return np.asarray(im, dtype=np.uint16)
        return np.asarray(im.convert("L"))


class Tetra3rs:
    def __init__(self) -> None:
        import tetra3rs

        self.mod = tetra3rs
        self.dbs: dict[tuple[float, float], Any] = {}

    def database(self, fov: float, size: tuple[int, int]) -> Any:
        key = (fov, size[1] / size[0])
        if key not in self.dbs:
            diag = fov * math.hypot(size[0], size[1]) / size[0]
            self.dbs[key] = self.mod.SolverDatabase.generate_from_gaia(max_fov_deg=diag * 1.1, min_fov_deg=fov * 0.9)
        return self.dbs[key]

    def solve(self, path: Path, fov: float, size: tuple[int, int]) -> Solution:
        img = grey(path)
        found = self.mod.extract_centroids(img)
        cs = found.centroids if hasattr(found, "centroids") else found
        h, w = img.shape
        r = self.database(fov, size).solve_from_centroids(
            cs, fov_estimate_deg=fov, image_width=w, image_height=h, fov_max_error_deg=0.1 * fov
        )
        return (float(r.ra_deg), float(r.dec_deg)) if r else None


class CedarSolve:
    def __init__(self) -> None:
        # cedar-solve 0.5 still calls numpy.math, which NumPy 2 removed: the standard module
        # it stood for.
        if not hasattr(np, "math"):
            np.math = math  # type: ignore[attr-defined]
        import tetra3

        self.t3 = tetra3.Tetra3(load_database="default_database")

    def solve(self, path: Path, fov: float, size: tuple[int, int]) -> Solution:
        with Image.open(path) as im:
            r = self.t3.solve_from_image(im.convert("L"), fov_estimate=fov, fov_max_error=0.1 * fov, solve_timeout=1000)
        return (float(r["RA"]), float(r["Dec"])) if r.get("RA") is not None else None


def fastest(call: Callable[[], Solution], rounds: int) -> tuple[Solution, float]:
    best, out = math.inf, None
    for _ in range(rounds):
        t = time.perf_counter()
        try:
            out = call()
        except Exception as e:  # a peer that raises on a frame has not solved it
            out = None
            print(f"    ({type(e).__name__}: {e})")
        best = min(best, time.perf_counter() - t)
    return out, best


def starid_call(path: Path, fov: Optional[float], from_array: bool) -> Callable[[], Solution]:
    image = starid.read_image(path) if from_array else path

    def call() -> Solution:
        r = starid.identify(image) if fov is None else starid.identify(image, fov_deg=fov)
        return (float(r.ra_deg), float(r.dec_deg)) if r.ok else None

    return call


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path)
    p.add_argument("--rounds", type=int, default=3)
    args = p.parse_args()
    truth = json.loads((args.folder / "truth.json").read_text())
    peers: dict[str, Any] = {}
    for name, make in (("tetra3rs", Tetra3rs), ("cedar-solve", CedarSolve)):
        try:
            peers[name] = make()
        except ImportError as e:
            print(f"{name} not installed ({e}): left out")
    columns = ["starid, field given", "starid, given, from array", "starid, field unknown", *peers]
    rows: list[list[str]] = []
    times: dict[str, list[float]] = {c: [] for c in columns}
    right = {c: 0 for c in columns}
    known = 0
    for name, t in truth.items():
        path = args.folder / name
        fov = None if t.get("fov_deg") is None else float(t["fov_deg"])
        with Image.open(path) as im:
            size = im.size
        calls: dict[str, Callable[[], Solution]] = {"starid, field unknown": starid_call(path, None, False)}
        if fov is not None:  # (a frame whose field nobody states: the unknown field's alone)
            calls["starid, field given"] = starid_call(path, fov, False)
            calls["starid, given, from array"] = starid_call(path, fov, True)
            if "tetra3rs" in peers:
                peers["tetra3rs"].database(fov, size)  # built once per field, not timed
            for peer_name, peer in peers.items():
                calls[peer_name] = lambda peer=peer, fov=fov: peer.solve(path, fov, size)
        truth_radec = (t["ra_deg"], t["dec_deg"]) if "ra_deg" in t else None
        known += truth_radec is not None
        cells = [name]
        for col in columns:
            if col not in calls:
                cells.append("(no field)")
                continue
            sol, dt = fastest(calls[col], args.rounds)
            if sol is None:
                cells.append(f"– ({1e3 * dt:.0f} ms)")
                continue
            times[col].append(dt)
            if truth_radec is not None:
                off = separation_deg(sol, truth_radec)
                ok = off <= 0.1
                right[col] += ok
                cells.append(f"{'right' if ok else 'WRONG'} {3600 * off:.0f}″ ({1e3 * dt:.0f} ms)")
            else:
                cells.append(f"{sol[0]:.3f} {sol[1]:+.3f} ({1e3 * dt:.0f} ms)")
        rows.append(cells)
        print(" | ".join(cells), flush=True)
    print()
    print(f"{len(truth)} images, each call the fastest of {args.rounds}; – : no solution")
    print()
    print("| image | " + " | ".join(columns) + " |")
    print("|---|" + "---|" * len(columns))
    for cells in rows:
        print("| " + " | ".join(cells) + " |")
    tried = [sum(1 for r in rows if r[i + 1] != "(no field)") for i in range(len(columns))]
    solved = [sum(1 for r in rows if r[i + 1][0] not in "–(") for i in range(len(columns))]
    print("| solved | " + " | ".join(f"{s}/{n}" for s, n in zip(solved, tried)) + " |")
    print("| right where known | " + " | ".join(f"{right[c]}/{known}" for c in columns) + " |")
    med = [f"{1e3 * statistics.median(times[c]):.1f} ms" if times[c] else "–" for c in columns]
    print("| median time, solved | " + " | ".join(med) + " |")


if __name__ == "__main__":
    main()
