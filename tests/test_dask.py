"""starid.dask on a real engine: a LocalCluster of 2 worker processes."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import Iterator

import numpy as np
import pandas as pd
import pytest

import starid

import dask.bag as db
import dask.dataframe as dd
import distributed

import starid.dask as sd

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::ResourceWarning", "ignore::UserWarning")

CAM = dict(fov_deg=12.0, image_size=(512, 512))


@pytest.fixture(scope="module")
def client() -> Iterator[distributed.Client]:
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture(scope="module")
def frames(bundled: starid.Catalog) -> list[starid.Frame]:
    return [starid.simulate(bundled, seed=s, noise_px=0.3, false_stars=s % 3, **CAM) for s in range(60)]


def _expected(frames: list[starid.Frame], bundled: starid.Catalog) -> list[starid.Identification]:
    return starid.identify_many([f.xy for f in frames], bundled, magnitudes=[f.magnitudes for f in frames], brightness_order=False, **CAM)


def test_bag_results_equal_identify_many(client: distributed.Client, frames: list[starid.Frame], bundled: starid.Catalog) -> None:
    bag = db.from_sequence([(k, f.xy, f.magnitudes) for k, f in enumerate(frames)], npartitions=6)
    got = sd.identify_frames(bag, bundled, brightness_order=False, **CAM).compute().set_index("frame").sort_index()
    spots = sd.identify_frames(bag, bundled, brightness_order=False, spots=True, **CAM).compute()
    want = _expected(frames, bundled)
    assert list(got.index) == list(range(len(frames)))
    for k, w in enumerate(want):
        row = got.loc[k]
        assert row.status == w.status and bool(row.ok) == w.ok and row.n_matched == w.n_matched
        if w.ok:
            assert np.array_equal([row.q_w, row.q_x, row.q_y, row.q_z], w.quaternion)
        ids = spots[spots.frame == k].sort_values("spot").catalog_id.to_numpy()
        assert np.array_equal(ids, w.ids)


def test_spot_table_and_parquet(client: distributed.Client, frames: list[starid.Frame], bundled: starid.Catalog, tmp_path: Path) -> None:
    rows = [(k, x, y, m) for k, f in enumerate(frames) for (x, y), m in zip(f.xy, f.magnitudes)]
    table = dd.from_pandas(pd.DataFrame(rows, columns=["frame", "x", "y", "mag"]), npartitions=5)
    got = sd.identify_frames(table, bundled, mag_column="mag", brightness_order=False, **CAM)
    out = tmp_path / "results"
    got.to_parquet(out)
    back = pd.read_parquet(out).set_index("frame").sort_index()
    want = _expected(frames, bundled)
    assert len(back) == len(frames)
    assert [back.loc[k].n_matched for k in range(len(frames))] == [w.n_matched for w in want]
    # A Parquet dataset of spots is an input too.
    spots_path = tmp_path / "spots"
    table.to_parquet(spots_path)
    again = sd.identify_frames(str(spots_path), bundled, mag_column="mag", brightness_order=False, **CAM).compute()
    assert sorted(again.frame) == list(range(len(frames)))


def test_a_malformed_frame_does_not_stop_the_job(client: distributed.Client, bundled: starid.Catalog) -> None:
    good = starid.simulate(bundled, seed=1, **CAM).xy
    bag = db.from_sequence([(0, good), (1, np.array([[np.nan, 1.0]])), (2, good)], npartitions=2)
    got = sd.identify_frames(bag, bundled, brightness_order=False, **CAM).compute().set_index("frame").sort_index()
    assert got.status.tolist() == ["identified", "invalid_input", "identified"]
    assert "frame" in got.loc[1].message


def test_records_of_the_wrong_shape_are_bad_rows_named_by_their_key(client: distributed.Client, bundled: starid.Catalog) -> None:
    good = starid.simulate(bundled, seed=1, **CAM).xy
    records = [(5, good), (99,), None, good, (6, good), ("x", good), (7, np.array([[np.nan, 1.0]] * 4))]
    bag = db.from_sequence(records, npartitions=2)
    got = sd.identify_frames(bag, bundled, brightness_order=False, **CAM).compute()
    assert len(got) == len(records)
    assert got.status.tolist() == ["identified"] + ["invalid_input"] * 3 + ["identified"] + ["invalid_input"] * 2
    assert got.frame.tolist()[:5] == [5, -1, -1, -1, 6]
    assert got.message.iloc[-1].startswith("frame 7:") and "not (frame_key, xy" in got.message.iloc[1]


def test_every_frame_once_when_a_worker_dies(client: distributed.Client, bundled: starid.Catalog) -> None:
    pool = [starid.simulate(bundled, seed=s, **CAM).xy for s in range(50)]
    bag = db.from_sequence([(k, pool[k % 50]) for k in range(4000)], npartitions=40)

    def slow(rec: tuple[int, np.ndarray]) -> tuple[int, np.ndarray]:
        time.sleep(0.002)
        return rec

    df = sd.identify_frames(bag.map(slow), bundled, brightness_order=False, **CAM)
    future = client.compute(df)

    def kill() -> None:
        time.sleep(1.5)
        worker = sorted(client.scheduler_info()["workers"])[0]
        client.run(os._exit, 1, workers=[worker])

    threading.Thread(target=kill, daemon=True).start()
    got = future.result(timeout=300)
    assert sorted(got.frame) == list(range(4000))
    assert got.ok.all()


def test_catalogue_travels_as_arrays(bundled: starid.Catalog) -> None:
    import pickle

    assert len(pickle.dumps(bundled)) < 45 * len(bundled) + 2000
    with pytest.raises(starid.InvalidInputError, match="Dask bag"):
        sd.identify_frames([(0, np.zeros((0, 2)))], bundled, **CAM)  # type: ignore[arg-type]


def test_image_files_on_the_cluster(client: distributed.Client, bundled: starid.Catalog, tmp_path: Path) -> None:
    from PIL import Image

    paths = []
    for seed in range(6):
        img, _ = starid.simulate_image(bundled, 12.0, (640, 480), seed=seed, hot_pixels=10)
        p = tmp_path / f"img{seed}.png"
        Image.fromarray(np.clip(img, 0, 65535).astype(np.uint16)).save(p)
        paths.append(str(p))
    paths.append(str(tmp_path / "missing.png"))
    df = sd.identify_images(paths, bundled, 12.0, partition_size=3).compute().set_index("frame")
    assert len(df) == 7
    for p in paths[:6]:
        want = starid.identify(p, bundled, 12.0)
        assert df.loc[p].ok and df.loc[p].n_matched == want.n_matched
    assert df.loc[paths[6]].status == "invalid_input" and "missing.png" in df.loc[paths[6]].message


def test_parquet_files_of_whole_frames_are_read_without_a_shuffle(
    client: distributed.Client, frames: list[starid.Frame], bundled: starid.Catalog, tmp_path: Path
) -> None:
    want = _expected(frames, bundled)
    folder = tmp_path / "whole"
    folder.mkdir()
    rows = [(k, x, y, m) for k, f in enumerate(frames) for (x, y), m in zip(f.xy, f.magnitudes)]
    table = pd.DataFrame(rows, columns=["frame", "x", "y", "mag"])
    # Three files of whole frames; within a file, two frames' rows interleaved.
    for i, part in enumerate(np.array_split(np.arange(len(frames)), 3)):
        sub = table[table.frame.isin(part)]
        a, b = sub[sub.frame == part[0]], sub[sub.frame == part[1]]
        mixed = pd.concat([a.iloc[::2], b.iloc[::2], a.iloc[1::2], b.iloc[1::2], sub[~sub.frame.isin(part[:2])]])
        mixed.to_parquet(folder / f"part{i}.parquet")
    assert sd._whole_frame_files(str(folder), "frame") is not None
    got = sd.identify_frames(str(folder), bundled, mag_column="mag", brightness_order=False, **CAM).compute()
    got = got.set_index("frame").sort_index()
    assert len(got) == len(frames)
    assert [got.loc[k].n_matched for k in range(len(frames))] == [w.n_matched for w in want]
    assert [got.loc[k].status for k in range(len(frames))] == [w.status for w in want]
    # A frame split across two files: not whole, so the rows are brought together first.
    split = tmp_path / "split"
    split.mkdir()
    table.iloc[: len(table) // 2 + 3].to_parquet(split / "a.parquet")
    table.iloc[len(table) // 2 + 3 :].to_parquet(split / "b.parquet")
    assert sd._whole_frame_files(str(split), "frame") is None
    again = sd.identify_frames(str(split), bundled, mag_column="mag", brightness_order=False, **CAM).compute()
    again = again.set_index("frame").sort_index()
    assert [again.loc[k].n_matched for k in range(len(frames))] == [w.n_matched for w in want]


def test_an_unknown_zero_point_is_learned_per_partition(client: distributed.Client, bundled: starid.Catalog) -> None:
    rng = np.random.default_rng(8)
    scenes = [starid.simulate_scene("K1", seed=s) for s in range(24)]
    mags = [f.magnitudes + 4.0 + rng.normal(0.0, 0.3, len(f.xy)) for f in scenes]
    kw = dict(fov_deg=scenes[0].fov_deg, image_size=scenes[0].image_size, mag_offset=None)
    records = [(k, f.xy, m) for k, (f, m) in enumerate(zip(scenes, mags))]
    for parts in (1, 3):
        got = sd.identify_frames(db.from_sequence(records, npartitions=parts), bundled, **kw).compute()
        got = got.set_index("frame").sort_index()
        # As identify_many over each partition's frames: the partition is the batch that learns.
        want: list[starid.Identification] = []
        chunks = db.from_sequence(records, npartitions=parts).map_partitions(lambda rs: [[r[0] for r in rs]]).compute()
        for keys in chunks:
            want += starid.identify_many([scenes[k].xy for k in keys], bundled, magnitudes=[mags[k] for k in keys], **kw)
        order = [k for keys in chunks for k in keys]
        assert len(chunks) == parts and sorted(order) == list(range(len(scenes)))
        assert [got.loc[k].n_matched for k in order] == [w.n_matched for w in want]
