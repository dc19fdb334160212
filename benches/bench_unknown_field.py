"""Frames of a field of view nobody gives: identified with neither ``fov_deg`` nor a range.

    python benches/bench_unknown_field.py [--frames 60] [--bands 4 8 8 25 25 50] [--false-stars 0] [--threads 1]
                                          [--one-camera [--batch]] [--covered-stage-pairs 50000]

Per band of fields of view: frames of 1024x768 px with a field drawn uniformly in the band,
stars of ``Catalog.deep(9)`` to a depth that leaves a few dozen in the field (magnitude
6 + 12 / fov, at most 9), 0.3 px and 0.2 mag of noise, magnitudes 3 mag off the catalogue's
(``mag_offset=None``). Prints the frames identified, wrong ids, frames whose field came out
more than 1 % off, and the median, 90th percentile and largest time per call (indexes built
on first use included). ``--threads 1`` identifies each frame through ``identify_many`` on one
thread: its stages in turn, the full one not begun beside the quick ones. ``--one-camera``
gives every frame of a band the field drawn for its first; with ``--batch`` the band's frames
are one ``identify_many`` call, which learns the field its identified frames agree on (times:
the call's, shared out per frame). ``--covered-stage-pairs`` sets the first stage's budget
(``starid._unknown_field.COVERED_STAGE_PAIRS``), for side-by-side runs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import starid
import starid._unknown_field as unknown_field


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--bands", type=float, nargs="+", default=[4, 8, 8, 25, 25, 50])
    p.add_argument("--false-stars", type=int, default=0)
    p.add_argument("--timeout-s", type=float, default=None, help="a time limit per frame (timeout_s)")
    p.add_argument("--threads", type=int, default=None, help="each frame alone through identify_many(threads=N)")
    p.add_argument("--one-camera", action="store_true", help="one field of view for all frames of a band")
    p.add_argument("--batch", action="store_true", help="with --one-camera: each band's frames as one batch")
    p.add_argument("--covered-stage-pairs", type=int, default=None, help="the first stage's pair budget")
    args = p.parse_args()
    if args.covered_stage_pairs is not None:
        unknown_field.COVERED_STAGE_PAIRS = args.covered_stage_pairs
    if args.batch and not args.one_camera:
        p.error("--batch needs --one-camera")
    truth = starid.Catalog.deep(9.0)
    size = (1024, 768)
    for lo, hi in zip(args.bands[::2], args.bands[1::2]):
        rng = np.random.default_rng(5)
        ok = wrong = off = 0
        times: list[float] = []
        frames: list[tuple[starid.Frame, float]] = []
        for seed in range(args.frames):
            fov = float(rng.uniform(lo, hi)) if not (args.one_camera and frames) else frames[0][1]
            frames.append((
                starid.simulate(
                    truth, fov, size, seed=seed, mag_limit=min(9.0, 6.0 + 12.0 / fov), noise_px=0.3, mag_noise=0.2,
                    false_stars=args.false_stars,
                ),
                fov,
            ))
        kw = dict(image_size=size, mag_offset=None, timeout_s=args.timeout_s)
        if args.batch:
            t0 = time.perf_counter()
            found = starid.identify_many([f.xy for f, _ in frames], magnitudes=[f.magnitudes + 3.0 for f, _ in frames], **kw)
            times = [(time.perf_counter() - t0) / len(frames)] * len(frames)
        else:
            found = []
            for f, _ in frames:
                t0 = time.perf_counter()
                if args.threads is None:
                    found.append(starid.identify(f.xy, magnitudes=f.magnitudes + 3.0, **kw))
                else:
                    found.append(starid.identify_many([f.xy], magnitudes=[f.magnitudes + 3.0], threads=args.threads, **kw)[0])
                times.append(time.perf_counter() - t0)
        for (f, fov), res in zip(frames, found):
            named = res.ids >= 0
            wrong += int(np.count_nonzero(named & (res.ids != f.true_ids)))
            ok += res.ok
            off += bool(res.ok and abs(res.fov_deg / fov - 1) > 0.01)
        ms = np.array(times) * 1e3
        print(
            f"{lo:g}-{hi:g} deg, {args.false_stars} false spots: identified {ok}/{args.frames}, wrong ids {wrong}, "
            f"field > 1 % off {off}; median {np.median(ms):.0f} ms, p90 {np.percentile(ms, 90):.0f} ms, "
            f"max {ms.max():.0f} ms"
        )


if __name__ == "__main__":
    main()
