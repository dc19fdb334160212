"""starid.dask on a LocalCluster against identify_many on the same machine, the same frames.

    python benches/bench_dask.py [--frames 1000000] [--partitions 100]
    python benches/bench_dask.py --parquet 200000 [--files 8]

Frames: 1 000 distinct simulated 12°/512 px frames (bundled catalogue, mag 6, 0.2 px, spots
in random order), repeated to ``--frames``; the Dask bag builds each partition's records on its
worker from the pool (shipped once), so what is timed is identification and the engine. Reports
frames/s for identify_many (all cores, one process) and for LocalClusters of 1 and 2 worker
processes (one thread each: identify_many inside a partition uses the worker's cores), the
ratio to identify_many, the workers' peak memory (RSS sampled every 0.2 s), and the engine's
cost per task (a job of ``--partitions`` one-frame partitions).

``--parquet N`` times a spot table instead: N frames as rows (frame, x, y) in ``--files``
Parquet files, each holding whole frames. One process reads them with pandas, splits the rows
into frames with numpy and calls identify_many; a LocalCluster of 2 workers runs
``starid.dask.identify_frames(path)``. Reported: both times, their ratio (target >= 0.8) and
whether the results are identical.
"""

from __future__ import annotations

import argparse
import threading
import time
from typing import Any

import numpy as np

import starid


def parquet_run(n: int, files: int) -> None:
    """identify_frames on a Parquet spot table against one process on the same files."""
    import os
    import tempfile

    import distributed
    import pandas as pd

    import starid.dask as sd

    cat = starid.Catalog.default()
    kw: dict[str, Any] = dict(fov_deg=12.0, image_size=(512, 512))
    pool = [starid.simulate(cat, seed=s, noise_px=0.2, mag_limit=6.0, **kw).xy for s in range(1000)]
    with tempfile.TemporaryDirectory() as d:
        per_file = -(-n // files)
        for f in range(files):
            ks = range(f * per_file, min((f + 1) * per_file, n))
            xy = np.concatenate([pool[k % 1000] for k in ks])
            fr = np.concatenate([np.full(len(pool[k % 1000]), k, np.int64) for k in ks])
            pd.DataFrame({"frame": fr, "x": xy[:, 0], "y": xy[:, 1]}).to_parquet(f"{d}/part{f}.parquet")
        names = sorted(os.listdir(d))
        starid.identify_many(pool[:10], cat, **kw)  # index built outside the timing
        t = time.perf_counter()
        table = pd.concat([pd.read_parquet(f"{d}/{f}") for f in names])
        keys = table.frame.to_numpy()
        cuts = np.flatnonzero(np.diff(keys)) + 1
        local = starid.identify_many(np.split(table[["x", "y"]].to_numpy(), cuts), cat, **kw)
        t_local = time.perf_counter() - t
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        with distributed.Client(cluster):
            sd.identify_frames(f"{d}/{names[0]}", cat, **kw).head(1, npartitions=1)  # workers warm
            t = time.perf_counter()
            got = sd.identify_frames(d, cat, **kw).compute()
            t_dask = time.perf_counter() - t
        cluster.close()
    got = got.set_index("frame").sort_index()
    same = got.n_matched.tolist() == [r.n_matched for r in local] and got.status.tolist() == [r.status for r in local]
    print(f"| frames | one process | LocalCluster, 2 workers | ratio | identical |")
    print("|---|---|---|---|---|")
    print(f"| {n:,} in {files} files | {t_local:.2f} s | {t_dask:.2f} s | {t_local / t_dask:.2f} | {same} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parquet", type=int, help="frames of a Parquet spot-table run (instead of the bag runs)")
    ap.add_argument("--files", type=int, default=8, help="Parquet files of the --parquet run")
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--partitions", type=int, default=100)
    ap.add_argument("--images", type=int, default=200, help="simulated 1024x768 PNG images for the image run")
    args = ap.parse_args()
    if args.parquet:
        parquet_run(args.parquet, args.files)
        return
    import dask.bag as db
    import distributed
    from dask.delayed import delayed

    import starid.dask as sd

    cat = starid.Catalog.default()
    kw: dict[str, Any] = dict(fov_deg=12.0, image_size=(512, 512), brightness_order=False)
    pool = [starid.simulate(cat, seed=s, noise_px=0.2, mag_limit=6.0, fov_deg=12.0, image_size=(512, 512)).xy for s in range(1000)]
    n, parts = args.frames, args.partitions
    per = -(-n // parts)
    frames = [pool[k % len(pool)] for k in range(n)]
    starid.identify_many(frames[:1000], cat, **kw)  # index built outside the timing
    t = time.perf_counter()
    local = starid.identify_many(frames, cat, **kw)
    t_local = time.perf_counter() - t
    ok_local = sum(r.ok for r in local)
    del local
    print(f"identify_many, one process, all cores: {n / t_local:,.0f} frames/s ({ok_local} of {n} identified)")

    def records(idx: list[int], pool: list[np.ndarray]) -> list[Any]:
        return [(k, pool[k % len(pool)]) for i in idx for k in range(i * per, min((i + 1) * per, n))]

    rows = []
    for workers in (1, 2):
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        with distributed.Client(cluster) as client:
            pool_node = delayed(pool, pure=True)
            bag = db.from_sequence(range(parts), npartitions=parts).map_partitions(records, pool_node)
            # Warm up: every worker imports starid and builds its index once.
            sd.identify_frames(db.from_sequence([(k, pool[k]) for k in range(4 * workers)], npartitions=2 * workers), cat, **kw).compute()
            peak: dict[str, int] = {}
            samples: dict[str, list[int]] = {}
            stop = threading.Event()

            def sample() -> None:
                import psutil  # a dependency of distributed

                while not stop.is_set():
                    for w, rss in client.run(lambda: psutil.Process().memory_info().rss).items():
                        peak[w] = max(peak.get(w, 0), rss)
                        samples.setdefault(w, []).append(rss)
                    time.sleep(0.2)

            th = threading.Thread(target=sample, daemon=True)
            th.start()
            t = time.perf_counter()
            # Reduced on the workers (as writing to Parquet would): results do not pile up in
            # worker memory waiting for the client, so the peak is what identification holds.
            import dask

            df = sd.identify_frames(bag, cat, **kw)
            ok, count = dask.compute(df.ok.sum(), df.frame.count())
            dt = time.perf_counter() - t
            stop.set()
            th.join()
            assert count == n
            t = time.perf_counter()
            sd.identify_frames(db.from_sequence([(k, pool[k % 1000]) for k in range(parts)], npartitions=parts), cat, **kw).compute()
            per_task = (time.perf_counter() - t) / parts
            # Flat memory: the RSS over the second quarter of the run against the last quarter.
            drift = max(
                (np.mean(v[-max(1, len(v) // 4):]) - np.mean(v[len(v) // 4: max(len(v) // 4 + 1, len(v) // 2)])) / 1e6
                for v in samples.values()
            )
            rows.append((workers, n / dt, int(ok), max(peak.values()) / 1e6, per_task, drift))
        cluster.close()
    # Images: PNG files read, extracted and identified on the workers, against one process.
    import tempfile

    from PIL import Image

    with tempfile.TemporaryDirectory() as d:
        paths = []
        for s in range(args.images):
            img, _ = starid.simulate_image(cat, 12.0, (1024, 768), seed=s, hot_pixels=50, gradient_e=200.0)
            p = f"{d}/img{s}.png"
            Image.fromarray(np.clip(img, 0, 65535).astype(np.uint16)).save(p)
            paths.append(p)
        t = time.perf_counter()
        ok_serial = sum(starid.identify(p, cat, 12.0).ok for p in paths)
        t_serial = time.perf_counter() - t
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        with distributed.Client(cluster):
            sd.identify_images(paths[:4], cat, 12.0, partition_size=2).compute()
            t = time.perf_counter()
            df_img = sd.identify_images(paths, cat, 12.0, partition_size=8).compute()
            t_img = time.perf_counter() - t
        cluster.close()
    image_row = (args.images / t_serial, ok_serial, args.images / t_img, int(df_img.ok.sum()))
    print("| setup | frames/s | identified | vs identify_many | peak RSS per worker | RSS drift, 2nd to 4th quarter | engine cost per task |")
    print("|---|---|---|---|---|---|---|")
    print(f"| identify_many (1 process, 2 cores) | {n / t_local:,.0f} | {ok_local:,} | 1.00 | - | - | - |")
    for workers, rate, ok, rss, per_task, drift in rows:
        print(f"| LocalCluster, {workers} worker{'s' if workers > 1 else ''} | {rate:,.0f} | {ok:,} | {rate * t_local / n:.2f} | "
              f"{rss:.0f} MB | {drift:+.0f} MB | {per_task * 1e3:.1f} ms |")
    rate_serial, ok_s, rate_img, ok_i = image_row
    print(f"images (1024x768 16-bit PNG, read + extract + identify): one process {rate_serial:.0f} images/s "
          f"({ok_s} identified); LocalCluster of 2 workers {rate_img:.0f} images/s ({ok_i} identified)")


if __name__ == "__main__":
    main()
