"""How fast Ctrl-C and ``timeout_s`` stop every kind of long call.

Ctrl-C: a real SIGINT arrives while each call works (a known camera's batch of frames, a hinted
batch, a batch of an unknown field of view, one unknown-field frame of 100 000 spots); the
delay from the signal to the KeyboardInterrupt in the caller is reported (target: 0.5 s).
Time limits: one frame of 100 000 random spots with ``timeout_s`` on each path; the overshoot
is reported against 10 % of the limit plus 50 ms.

    python benches/bench_interrupt.py [--frames 100000] [--after 1.0] [--timeout 1.0] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import signal
import threading
import time
from typing import Any, Callable

import numpy as np

import starid

SIZE = (512, 512)


def interrupted(call: Callable[[], Any], after: float) -> str:
    """The delay from a SIGINT sent ``after`` seconds into ``call`` to its KeyboardInterrupt."""
    sent = [0.0]

    def fire() -> None:
        sent[0] = time.perf_counter()
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(after, fire)
    t0 = time.perf_counter()
    timer.start()
    try:
        call()
        timer.cancel()
        return f"finished in {time.perf_counter() - t0:.2f} s, before the signal"
    except KeyboardInterrupt:
        delay = time.perf_counter() - sent[0]
        return f"KeyboardInterrupt {delay * 1e3:4.0f} ms after SIGINT ({'met' if delay <= 0.5 else 'MISSED'})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100_000, help="frames of each batch")
    ap.add_argument("--after", type=float, default=1.0, help="seconds before SIGINT")
    ap.add_argument("--timeout", type=float, default=1.0, help="timeout_s of the time-limit runs")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    rng = np.random.default_rng(0)
    distinct = [starid.simulate(None, 12.0, SIZE, seed=s, noise_px=0.2).xy for s in range(1000)]
    frames = (distinct * (args.frames // len(distinct) + 1))[: args.frames]
    hopeless = [rng.uniform(0, SIZE[0], (60, 2)) for _ in range(100)]
    hopeless = (hopeless * (args.frames // len(hopeless) + 1))[: args.frames]
    crowd = rng.uniform(0, SIZE[0], (100_000, 2))
    hint = (83.0, -5.0, 0.0)
    calls: dict[str, Callable[[], Any]] = {
        "batch, known camera": lambda: starid.identify_many(
            frames, fov_deg=12.0, image_size=SIZE, brightness_order=False
        ),
        "batch, hinted": lambda: starid.identify_many(hopeless, fov_deg=12.0, image_size=SIZE, attitude_hint=hint),
        "batch, unknown field": lambda: starid.identify_many(hopeless, image_size=SIZE, fov_range_deg=(8.0, 16.0)),
        "one frame of 1e5 spots, unknown field": lambda: starid.identify(crowd, image_size=SIZE),
    }
    # Indexes are built before the clocks start.
    starid.identify(crowd[:100], image_size=SIZE, timeout_s=0.1)
    starid.identify(crowd[:100], image_size=SIZE, fov_range_deg=(8.0, 16.0), timeout_s=0.1)
    starid.identify(crowd[:100], fov_deg=12.0, image_size=SIZE)
    print(f"Ctrl-C after {args.after} s")
    for name, call in calls.items():
        for k in range(args.repeat):
            print(f"  {name:40s} run {k}: {interrupted(call, args.after)}")
    limit = args.timeout
    print(f"timeout_s={limit} on one frame of {len(crowd)} random spots (target: {limit * 1.1 + 0.05:.3f} s)")
    timed: dict[str, Callable[[], Any]] = {
        "known camera": lambda: starid.identify(crowd, fov_deg=12.0, image_size=SIZE, timeout_s=limit),
        "hinted": lambda: starid.identify(crowd, fov_deg=12.0, image_size=SIZE, attitude_hint=hint, timeout_s=limit),
        "unknown field": lambda: starid.identify(crowd, image_size=SIZE, timeout_s=limit),
        "field range": lambda: starid.identify(crowd, image_size=SIZE, fov_range_deg=(8.0, 16.0), timeout_s=limit),
    }
    for method in starid.METHODS:
        if method != "auto":
            timed[f"known camera, method {method}"] = (
                lambda m=method: starid.identify(crowd, fov_deg=12.0, image_size=SIZE, method=m, timeout_s=limit)
            )
    for name, call in timed.items():
        for k in range(args.repeat):
            t0 = time.perf_counter()
            res = call()
            took = time.perf_counter() - t0
            verdict = "met" if took <= limit * 1.1 + 0.05 else "MISSED"
            print(f"  {name:40s} run {k}: {took:.3f} s, status {res.status} ({verdict})")


if __name__ == "__main__":
    main()
