"""Calls of ``starid.identify`` on a frame of one spot (status ``too_few_stars``: the core returns
at once), so that what is timed or counted is the call itself: argument handling, the native
call and the result object. Used by ``benches/callgrind_instructions.sh`` (instructions per call)
and on its own for wall time:

    python benches/call_overhead.py [--calls 200000] [--form plain|unknown-zero-point|hinted]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import starid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--calls", type=int, default=200_000)
    p.add_argument("--form", choices=["plain", "unknown-zero-point", "hinted"], default="plain")
    args = p.parse_args()
    cat = starid.Catalog.default()
    xy = np.array([[100.0, 200.0]])
    mags = np.array([2.0])
    kw: dict[str, object] = {"fov_deg": 12.0, "image_size": (512, 512), "magnitudes": mags}
    if args.form == "unknown-zero-point":
        kw["mag_offset"] = None
    elif args.form == "hinted":
        kw.update(attitude_hint=np.array([1.0, 0.0, 0.0, 0.0]), hint_uncertainty_deg=1.0, hint_fallback=False)
    res = starid.identify(xy, cat, **kw)  # builds the index outside the count
    assert res.status == "too_few_stars", res.status
    t0 = time.perf_counter()
    for _ in range(args.calls):
        starid.identify(xy, cat, **kw)
    dt = time.perf_counter() - t0
    print(f"{args.form}: {dt / max(args.calls, 1) * 1e6:.2f} us per call ({args.calls} calls)")


if __name__ == "__main__":
    main()
