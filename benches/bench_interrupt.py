"""How fast Ctrl-C stops a long batch: SIGINT arrives while ``identify_many`` works through a
million frames (1 000 distinct frames, each repeated 1 000 times); reports the delay from the
signal to the KeyboardInterrupt in the caller (the issue's target: within 0.5 s).

    python benches/bench_interrupt.py [--frames 1000000] [--after 2.0] [--repeat 3]
"""

from __future__ import annotations

import argparse
import signal
import time

import starid


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--after", type=float, default=2.0, help="seconds before SIGINT")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    distinct = [starid.simulate(None, 12.0, (512, 512), seed=s, noise_px=0.2).xy for s in range(1000)]
    frames = (distinct * (args.frames // len(distinct) + 1))[: args.frames]
    sent = [0.0]

    def fire(*_: object) -> None:
        sent[0] = time.perf_counter()
        signal.raise_signal(signal.SIGINT)

    for k in range(args.repeat):
        signal.signal(signal.SIGALRM, fire)
        signal.setitimer(signal.ITIMER_REAL, args.after)
        t0 = time.perf_counter()
        try:
            starid.identify_many(frames, fov_deg=12.0, image_size=(512, 512), brightness_order=False)
            print(f"run {k}: finished in {time.perf_counter() - t0:.1f} s before the signal")
        except KeyboardInterrupt:
            delay = time.perf_counter() - sent[0]
            print(f"run {k}: SIGINT after {sent[0] - t0:.2f} s, KeyboardInterrupt {delay * 1e3:.0f} ms later")


if __name__ == "__main__":
    main()
