"""Scale-out on Dask: identify archives of frames on a cluster (``pip install 'starid-solver[dask]'``).

The work divides by partition: each Dask task identifies one partition's frames with
:func:`starid.identify_many` (Rust threads, GIL released, every core of the worker). The
catalogue travels once per worker, as its arrays (a :class:`starid.Catalog` pickles to 40 bytes
a star, never its indexes); each worker builds the pair index on its first partition and keeps
it for every later one (cached by the catalogue's content), so a worker holds one catalogue,
its index (about 8 MB for the bundled catalogue at 12°) and the partition in flight.

>>> import starid, starid.dask, dask.bag as db                      # doctest: +SKIP
>>> frames = db.from_sequence([(k, starid.simulate(seed=k).xy) for k in range(1000)], npartitions=8)
>>> df = starid.dask.identify_frames(frames, fov_deg=12.0, image_size=(512, 512))
>>> df.to_parquet("results/")                                      # or df.compute()

Point the same code at a real cluster by creating a ``dask.distributed.Client`` for it (a
``dask_jobqueue`` cluster on a batch system, ``dask_kubernetes`` on Kubernetes) before
calling: the functions here only build the graph.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np
import pandas as pd

from . import _starid
from ._catalog import Catalog, CatalogLike, resolve_catalog
from ._errors import InvalidInputError
from ._batch import identify_many
from ._args import Identification, _camera, _invalid
from ._read import read_image

try:
    import dask.bag as dask_bag
    import dask.dataframe as dd
    import pyarrow.parquet as pq  # type: ignore[import-untyped]
    from dask.delayed import delayed
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("starid.dask needs Dask: pip install 'starid-solver[dask]'") from None

__all__ = ["FRAME_COLUMNS", "SPOT_COLUMNS", "identify_frames", "identify_images"]

#: Columns of the per-frame result.
FRAME_COLUMNS = {
    "frame": "object",
    "status": "str",
    "ok": "bool",
    "method": "str",
    "ra_deg": "float64",
    "dec_deg": "float64",
    "roll_deg": "float64",
    "q_w": "float64",
    "q_x": "float64",
    "q_y": "float64",
    "q_z": "float64",
    "mirrored": "bool",
    "fov_deg": "float64",
    "focal_px": "float64",
    "k1": "float64",
    "learned_mag_offset": "float64",
    "n_spots": "int64",
    "n_matched": "int64",
    "false_match_probability": "float64",
    "time_s": "float64",
    "message": "str",
}

#: Columns of the per-spot result.
SPOT_COLUMNS = {"frame": "object", "spot": "int64", "catalog_id": "int64", "residual_arcsec": "float64"}

#: The frame key of a record that has none (a record that is not ``(key, xy[, magnitudes])``).
MISSING_KEY: dict[str, Any] = {"int64": -1, "str": ""}


def _key_fits(key: Any, frame_dtype: str) -> bool:
    """Whether a record's key can stand in a key column of ``frame_dtype``."""
    if frame_dtype.startswith("int"):
        return isinstance(key, (int, np.integer)) and not isinstance(key, (bool, np.bool_))
    return True


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# Catalogues already on this worker, by content: their pair indexes are built once.
_WORKER_CATALOGS: dict[str, Catalog] = {}


def _fingerprint(cat: Catalog) -> str:
    h = hashlib.sha1()
    for a in (cat.ids, cat.unit_vectors, cat.mag):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _worker_catalog(cat: Optional[Catalog], key: str) -> Optional[Catalog]:
    """The worker's own copy of a catalogue (and so its cached indexes); None (the bundled
    catalogue each batch chooses) stays None."""
    return None if cat is None else _WORKER_CATALOGS.setdefault(key, cat)


def _identify_records(
    records: list[Any], cat: Optional[Catalog], key: str, kwargs: dict[str, Any], spots: bool, frame_dtype: str
) -> pd.DataFrame:
    """One partition: records ``(frame_key, xy[, magnitudes])`` → result rows. A record of
    another shape is an ``invalid_input`` row (its key, or :data:`MISSING_KEY` without one);
    every message names the frame by its key."""
    cat = _worker_catalog(cat, key)
    missing = MISSING_KEY.get(frame_dtype, MISSING_KEY["str"])
    keys: list[Any] = []
    xys: list[Any] = []
    mags: list[Any] = []
    bad: dict[int, str] = {}
    for i, r in enumerate(records):
        if isinstance(r, (tuple, list)) and len(r) in (2, 3) and not _key_fits(r[0], frame_dtype):
            keys.append(missing)
            xys.append(np.empty((0, 2)))
            mags.append(None)
            bad[i] = f"record {i} of its partition has key {_short(r[0])}, not of the keys' type {frame_dtype}"
        elif isinstance(r, (tuple, list)) and len(r) in (2, 3):
            keys.append(r[0])
            xys.append(r[1])
            mags.append(r[2] if len(r) == 3 else None)
        else:
            keys.append(missing)
            xys.append(np.empty((0, 2)))
            mags.append(None)
            bad[i] = f"record {i} of its partition is not (frame_key, xy[, magnitudes]): {type(r).__name__} {_short(r)}"
    have_mags = any(m is not None for m in mags)
    return _identify_frames_of(keys, xys, mags if have_mags else None, cat, kwargs, spots, frame_dtype, bad)


def _identify_frames_of(
    keys: Any,
    xys: list[Any],
    mags: Optional[list[Any]],
    cat: Optional[Catalog],
    kwargs: dict[str, Any],
    spots: bool,
    frame_dtype: str,
    bad: Optional[dict[int, str]] = None,
) -> pd.DataFrame:
    """The result rows of one partition's frames (``bad``: frames already refused, and why)."""
    bad = bad or {}
    results = identify_many(xys, cat, magnitudes=mags, **kwargs) if len(xys) else []
    for i, r in enumerate(results):
        if i in bad:
            results[i] = _invalid(bad[i], 0)
        elif r.status == "invalid_input":
            # The batch names a frame by its place in the partition: the key is its name.
            msg = re.sub(r"^frame \d+: ", "", r.message or "")
            results[i] = _invalid(f"frame {keys[i]}: {msg}", len(r.ids))
    key_arr = pd.Series(keys, dtype=frame_dtype)
    cols = _starid.result_columns(results, spots)
    if spots:
        table = pd.DataFrame(
            {
                "frame": key_arr.iloc[cols["spot_frame"]].to_numpy(),
                "spot": cols["spot"],
                "catalog_id": cols["catalog_id"],
                "residual_arcsec": cols["residual_arcsec"],
            }
        )
        return table.astype(dict(SPOT_COLUMNS, frame=frame_dtype))
    return _frame_table(key_arr.to_numpy(), cols, frame_dtype)


def _frame_table(keys: Any, cols: dict[str, Any], frame_dtype: str) -> pd.DataFrame:
    """The per-frame table (:data:`FRAME_COLUMNS`) of ``result_columns`` output."""
    q = cols["quaternion"]
    table = pd.DataFrame(
        {
            "frame": keys,
            **{k: cols[k] for k in ("status", "ok", "method", "ra_deg", "dec_deg", "roll_deg")},
            "q_w": q[:, 0],
            "q_x": q[:, 1],
            "q_y": q[:, 2],
            "q_z": q[:, 3],
            **{k: cols[k] for k in ("mirrored", "fov_deg", "focal_px", "k1", "learned_mag_offset", "n_spots", "n_matched",
                                     "false_match_probability", "time_s", "message")},
        }
    )
    return table.astype(dict(FRAME_COLUMNS, frame=frame_dtype))


def _frames_of_spots(
    part: pd.DataFrame, frame: str, x: str, y: str, mag: Optional[str]
) -> tuple[Any, list[Any], Optional[list[Any]]]:
    """Rows of one partition, one per spot, grouped into frames without a loop per frame: the
    frames' keys (in order of first appearance), their (N, 2) centroids and magnitudes (rows
    in their order within each frame)."""
    if "_starid_row" in part.columns:
        part = part.sort_values("_starid_row", kind="stable")
    codes, uniques = pd.factorize(part[frame], sort=False)
    xy = np.column_stack([part[x].to_numpy(np.float64), part[y].to_numpy(np.float64)])
    m = None if mag is None else part[mag].to_numpy(np.float64)
    if len(codes) > 1 and not (np.diff(codes) >= 0).all():
        order = np.argsort(codes, kind="stable")
        codes, xy = codes[order], xy[order]
        m = None if m is None else m[order]
    cuts = np.flatnonzero(np.diff(codes)) + 1
    xys = np.split(xy, cuts)
    mags = None if m is None else np.split(m, cuts)
    return np.asarray(uniques), xys, mags


def _parquet_files(path: str) -> list[str]:
    """The Parquet files of a dataset: the file itself, or those under a folder, in order."""
    p = Path(path)
    if p.is_file():
        return [str(p)]
    return sorted(str(f) for f in p.rglob("*.parquet") if f.is_file())


def _whole_frame_files(path: str, frame: str) -> Optional[list[str]]:
    """The dataset's files, when their statistics show every frame within one file (the
    files' key ranges are disjoint), in key order; None when that cannot be shown."""
    files = _parquet_files(path)
    if len(files) < 1 or "://" in path:
        return None
    ranges = []
    for f in files:
        meta = pq.ParquetFile(f).metadata
        names = [meta.schema.column(i).name for i in range(meta.num_columns)]
        if frame not in names:
            return None
        col = names.index(frame)
        lo = hi = None
        for g in range(meta.num_row_groups):
            st = meta.row_group(g).column(col).statistics
            if st is None or not st.has_min_max:
                return None
            lo = st.min if lo is None else min(lo, st.min)
            hi = st.max if hi is None else max(hi, st.max)
        if lo is not None:
            ranges.append((lo, hi, f))
    ranges.sort(key=lambda r: r[0])
    if any(a[1] >= b[0] for a, b in zip(ranges, ranges[1:])):
        return None
    return [f for _, _, f in ranges]


def _read_file(path: str, columns: list[str]) -> pd.DataFrame:
    return pd.read_parquet(path, columns=columns)


def identify_frames(
    frames: Union["dask_bag.Bag", "dd.DataFrame", str],
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    image_size: Optional[tuple[float, float]] = None,
    *,
    spots: bool = False,
    frame_dtype: Optional[str] = None,
    frame_column: str = "frame",
    x_column: str = "x",
    y_column: str = "y",
    mag_column: Optional[str] = None,
    **kwargs: Any,
) -> "dd.DataFrame":
    """Identify centroid frames on Dask; returns a lazy Dask DataFrame.

    Parameters
    ----------
    frames
        A Dask bag of records ``(frame_key, xy)`` or ``(frame_key, xy, magnitudes)`` (``xy`` an
        (N, 2) array), or a Dask DataFrame with one row per spot (columns ``frame_column``,
        ``x_column``, ``y_column`` and optionally ``mag_column``), or the path of a Parquet
        dataset of such rows. Rows of one frame are brought into one partition (a shuffle on
        the frame column) unless the frame column is already the sorted index, or the Parquet
        files' statistics show that each file holds whole frames (then each file is one
        partition, read as it is). Within a partition the rows are grouped into frames with
        numpy, not a loop per frame.
    catalog, fov_deg, image_size, **kwargs
        As :func:`starid.identify_many` (``camera=``, ``fov_range_deg=``, ``method=``, the
        settings...). The catalogue is sent once per worker.
    frame_dtype : str, optional
        The frame keys' dtype in the result (by default that of the spot table's frame column,
        or of the first record's key: ``"int64"`` for integers, else ``"str"``).
    spots : bool
        Return one row per spot (``frame, spot, catalog_id, residual_arcsec``) instead of one
        per frame (:data:`FRAME_COLUMNS`).

    Returns
    -------
    dask.dataframe.DataFrame
        Lazy: ``.compute()``, ``.to_parquet(...)``. Results equal :func:`starid.identify_many`'s,
        frame for frame; a malformed frame or record gets status ``invalid_input``, never stops
        the job. With ``mag_offset=None`` (a zero point to learn), each partition is the batch
        that learns it, as ``identify_many`` over that partition's frames would: a job of many
        partitions does not pool them. So is the centroid noise (``learn_noise``), the focal
        length of a field given as an estimate, the field of view where none is given, and with
        ``catalog=None`` the bundled catalogue chosen for the frames' magnitudes.
    """
    if fov_deg is not None or kwargs.get("camera") is not None:
        _camera(kwargs.get("camera"), fov_deg, image_size)  # a bad camera is refused here, not in every partition
    # catalog=None: each partition's identify_many chooses the bundled catalogue for its frames.
    cat = None if catalog is None else resolve_catalog(catalog)
    key = "" if cat is None else _fingerprint(cat)
    cat_node = delayed(cat, pure=True)
    if "magnitudes" in kwargs:
        raise InvalidInputError("give magnitudes inside the records (or mag_column), not as magnitudes=")
    kw = dict(kwargs, fov_deg=fov_deg, image_size=image_size)

    def meta_for(ftype: str) -> pd.DataFrame:
        cols = dict(SPOT_COLUMNS if spots else FRAME_COLUMNS, frame=ftype)
        return pd.DataFrame({k: pd.Series(dtype=v) for k, v in cols.items()})

    whole_frames = False
    if isinstance(frames, (str, os.PathLike)):
        path = os.fspath(frames)
        files = _whole_frame_files(path, frame_column)
        if files:
            # Each file holds whole frames: one partition a file, no shuffle.
            columns = [c for c in (frame_column, x_column, y_column, mag_column) if c]
            schema_meta = pq.read_schema(files[0]).empty_table().to_pandas()
            missing_cols = [c for c in columns if c not in schema_meta.columns]
            if missing_cols:
                raise InvalidInputError(f"the spot table has no column {missing_cols[0]!r} (columns: {list(schema_meta.columns)})")
            frames = dd.from_map(  # type: ignore[no-untyped-call]
                _read_file, files, columns=columns, meta=schema_meta[columns], enforce_metadata=False
            )
            whole_frames = True
        else:
            frames = dd.read_parquet(path)
    if isinstance(frames, dask_bag.Bag):
        if frame_dtype is None:
            first = frames.take(1, npartitions=1, warn=False)  # type: ignore[no-untyped-call]
            head = first[0][0] if first and isinstance(first[0], (tuple, list)) and first[0] else None
            is_int = isinstance(head, (int, np.integer)) and not isinstance(head, (bool, np.bool_))
            frame_dtype = "int64" if is_int else "str"
        meta = meta_for(frame_dtype)
        run = delayed(_identify_records, pure=True)
        parts = [run(p, cat_node, key, kw, spots, frame_dtype) for p in frames.to_delayed()]  # type: ignore[no-untyped-call]
        result: dd.DataFrame = dd.from_delayed(parts, meta=meta, verify_meta=False)
        return result
    if isinstance(frames, dd.DataFrame):
        df = frames
        for col in (x_column, y_column) + ((mag_column,) if mag_column else ()):
            if col not in df.columns:
                raise InvalidInputError(f"the spot table has no column {col!r} (columns: {list(df.columns)})")
        if whole_frames:
            pass
        elif frame_column not in df.columns:
            if df.index.name != frame_column:
                raise InvalidInputError(f"the spot table has no frame column {frame_column!r}")
            # Sorted by frame already: whole frames per partition, rows in their order.
            df = df.reset_index() if df.known_divisions else df.reset_index().shuffle(on=frame_column)
        else:
            # A shuffle brings each frame's rows together but not in order: the original row
            # order (the index) travels along and is restored, so the spots keep theirs.
            df = df.assign(_starid_row=df.index).shuffle(on=frame_column)

        ftype = frame_dtype or str(df[frame_column].dtype)
        meta = meta_for(ftype)

        def part(p: pd.DataFrame, c: Optional[Catalog]) -> pd.DataFrame:
            keys, xys, mags = _frames_of_spots(p, frame_column, x_column, y_column, mag_column)
            return _identify_frames_of(keys, xys, mags, _worker_catalog(c, key), kw, spots, ftype)

        mapped: dd.DataFrame = df.map_partitions(  # type: ignore[no-untyped-call,unused-ignore]
            part, cat_node, meta=meta, enforce_metadata=False, align_dataframes=False
        )
        return mapped
    raise InvalidInputError(f"frames must be a Dask bag, a Dask DataFrame or a Parquet path, not {type(frames).__name__}")


def _read_any(path: str) -> np.ndarray:
    """An image from a local path or any fsspec URL (``s3://``, ``gcs://``, ``https://``...)."""
    if "://" not in path or path.startswith("file://"):
        return read_image(path[7:] if path.startswith("file://") else path)
    try:
        import fsspec  # type: ignore[import-untyped,unused-ignore]
    except ImportError as e:  # pragma: no cover - fsspec comes with dask
        raise ImportError("reading image URLs needs fsspec: pip install 'starid-solver[dask]'") from None
    import tempfile

    suffix = "".join(Path(path.split("?")[0]).suffixes[-2:]) or ".img"
    with fsspec.open(path, "rb") as src, tempfile.NamedTemporaryFile(suffix=suffix) as tmp:
        tmp.write(src.read())
        tmp.flush()
        return read_image(tmp.name)


def _identify_paths(
    paths: list[str], cat: Optional[Catalog], key: str, kwargs: dict[str, Any], extract: dict[str, Any]
) -> pd.DataFrame:
    """One partition of image files: read, extract, identify; a file that cannot be read gets
    status ``invalid_input`` with the reason."""
    # None: each image gets the bundled catalogue its field needs, as identify_image chooses.
    cat = None if cat is None else _worker_catalog(cat, key)
    kw = dict(kwargs)
    fov = kw.pop("fov_deg", None)
    results: list[Optional[Identification]] = [None] * len(paths)
    images, where = [], []
    for i, p in enumerate(paths):
        try:
            images.append(_read_any(p))
            where.append(i)
        except (ValueError, OSError, ImportError) as e:
            results[i] = _invalid(f"{p}: {e}", 0)
    # The partition's images as one batch: they learn their magnitudes' zero point together.
    if images:
        batch = identify_many(images, cat, fov, extract=extract, **kw)
        for i, r in zip(where, batch):
            results[i] = r if r.status != "invalid_input" else _invalid(f"{paths[i]}: {r.message}", len(r.ids))
    done = [r for r in results if r is not None]
    return _frame_table(np.asarray(paths, dtype=object), _starid.result_columns(done, False), "str")


def identify_images(
    paths: Union[list[str], "dask_bag.Bag"],
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    *,
    partition_size: int = 16,
    extract: Optional[dict[str, Any]] = None,
    **kwargs: Any,
) -> "dd.DataFrame":
    """Identify image files (local paths or any fsspec URL) on Dask: one row per image
    (:data:`FRAME_COLUMNS`, ``frame`` the path), read, extracted and identified on the workers.

    ``paths`` is a list (cut into partitions of ``partition_size`` images) or a Dask bag of
    paths; ``extract`` holds :func:`starid.extract_centroids` settings; other arguments as
    :func:`starid.identify` (the image size comes from each image). A file that cannot be read
    gets status ``invalid_input``, naming it.
    """
    cat = None if catalog is None else resolve_catalog(catalog)
    key = "" if cat is None else _fingerprint(cat)
    cat_node = delayed(cat, pure=True)
    kw = dict(kwargs, fov_deg=fov_deg)
    if isinstance(paths, dask_bag.Bag):
        bag = paths
    else:
        if not isinstance(partition_size, int) or partition_size < 1:
            raise InvalidInputError(f"partition_size must be a positive integer, got {partition_size!r}")
        items = [str(p) for p in paths]
        if not items:
            raise InvalidInputError("no image paths given")
        bag = dask_bag.from_sequence(items, partition_size=partition_size)  # type: ignore[no-untyped-call]
    meta = pd.DataFrame({k: pd.Series(dtype=v) for k, v in dict(FRAME_COLUMNS, frame="str").items()})
    run = delayed(_identify_paths, pure=True)
    parts = [run(p, cat_node, key, kw, dict(extract or {})) for p in bag.to_delayed()]  # type: ignore[no-untyped-call]
    result: dd.DataFrame = dd.from_delayed(parts, meta=meta, verify_meta=False)
    return result
