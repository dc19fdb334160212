"""Batches: many frames of one camera, identified by the core in parallel (``identify_many``),
and images read and extracted on threads first."""

from __future__ import annotations

import numbers
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Mapping, Optional, Sequence, Sized, TypeVar, cast

import numpy as np
import numpy.typing as npt

from . import _starid
from ._catalog import Catalog, CatalogLike, resolve_catalog, resolve_catalog_for
from ._centroids import Centroids
from ._errors import InvalidInputError
from ._unknown_field import identify_rough_field, identify_unknown_field
from ._args import (
    _F64,
    _UNSET,
    Identification,
    _camera,
    _config,
    _flag,
    _fov_range,
    _from_pixel_origin,
    _hint,
    _image_size,
    _invalid,
    _is_image,
    _magnitudes,
    _positive,
    _xy,
)
from .images import extract_centroids, rough_field_applies, settings_of

T = TypeVar("T")

__all__ = ["identify_many"]


def identify_many(
    frames: Sequence[npt.ArrayLike],
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    image_size: Optional[tuple[float, float]] = None,
    *,
    camera: Optional[Any] = None,
    fov_range_deg: Optional[tuple[float, float]] = None,
    magnitudes: Optional[Sequence[Optional[npt.ArrayLike]]] = None,
    attitude_hint: Optional[Any] = None,
    hint_uncertainty_deg: float = 1.0,
    hint_fallback: bool = True,
    threads: Optional[int] = None,
    config: Optional[Any] = None,
    mag_offset: Optional[float] = _UNSET,
    pixel_origin: str = "corner",
    **settings: Any,
) -> list[Identification]:
    """Identify many frames of one camera in parallel (Rust threads, GIL released).

    A malformed frame (NaN, a wrong shape, a centroid far off the sensor) does not stop the
    batch: its result has status ``"invalid_input"`` and the reason, naming the frame, in
    ``message``. Ctrl-C stops the batch within a frame's time and raises KeyboardInterrupt.

    Arguments as :func:`identify` (every one of them, ``fov_range_deg``, the hint and the
    settings included; ``attitude_hint`` is one hint for every frame or a list of one per frame,
    None entries identified lost in space); ``frames`` is a sequence of (N_i, 2) centroid arrays and
    ``magnitudes`` an optional sequence of per-frame magnitude arrays (or None entries).
    ``threads`` limits the worker threads (None: all cores); ``timeout_s`` applies to each
    frame. Results come in input order and
    do not depend on the thread count.

    ``frames`` may also be images (paths or arrays, as :func:`identify` takes): they are read,
    extracted and identified in parallel threads (the core releases the GIL), each with its own
    size; an image that cannot be read gets status ``"invalid_input"`` naming it. With a known
    field of view their spots are identified as one batch per image size, so that the images
    learn their magnitudes' zero point together (below).

    A batch of one camera shares a magnitude zero point: with ``mag_offset=None`` the frames
    identified without it measure it, and the frames nothing identified are searched again
    with it, magnitude-gated (``learn_zero_point``, on by default; such a frame reports it as
    ``learned_mag_offset`` and its ``time_s`` counts both searches).

    Examples
    --------
    >>> import starid
    >>> frames = [starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=s).xy for s in range(4)]
    >>> [r.ok for r in starid.identify_many(frames, fov_deg=12.0, image_size=(512, 512))]
    [True, True, True, True]
    """
    if isinstance(frames, Sequence) and len(frames) > 0 and all(isinstance(f, Centroids) for f in frames):
        # Spots extracted by starid: positions, instrument magnitudes and the sensor size.
        if magnitudes is not None:
            raise InvalidInputError("Centroids carry their magnitudes: do not pass magnitudes=")
        cents = cast(Sequence[Centroids], frames)
        if len({c.image_size for c in cents}) > 1:
            raise InvalidInputError("a batch is one camera: these Centroids come from images of different sizes")
        if image_size is None and camera is None:
            image_size = cents[0].image_size
        if mag_offset is _UNSET and config is None:
            mag_offset = None  # instrument magnitudes: their zero point is unknown
        magnitudes = [c.magnitudes if np.isfinite(c.magnitudes).all() else None for c in cents]
        frames = [c.xy for c in cents]
    if mag_offset is not _UNSET:
        settings["mag_offset"] = mag_offset
    if isinstance(frames, (str, bytes, os.PathLike, Mapping)) or not isinstance(frames, (Sequence, np.ndarray)):
        raise InvalidInputError(
            f"frames must be a sequence of frames (a list of (N, 2) arrays or of images), got {type(frames).__name__}"
        )
    if pixel_origin != "corner":
        frames = [_from_pixel_origin(f, pixel_origin) for f in frames]
    if len(frames) > 0 and _is_image(frames[0]):
        if magnitudes is not None:
            raise InvalidInputError("images' magnitudes come from their spots: do not pass magnitudes=")
        return _image_batch(
            frames, catalog, fov_deg, threads,
            dict(settings, camera=camera, fov_range_deg=fov_range_deg, attitude_hint=attitude_hint,
                 hint_uncertainty_deg=hint_uncertainty_deg, hint_fallback=hint_fallback, config=config, image_size=image_size),
        )
    cam = _camera(camera, fov_deg, image_size)
    if cam is None:
        w, h = _image_size(image_size)
        rng = None if fov_range_deg is None else _fov_range(fov_range_deg)
    elif fov_range_deg is not None:
        raise InvalidInputError("give fov_deg (a known field of view) or fov_range_deg (an unknown one), not both")
    # One malformed frame does not stop the batch: it gets status "invalid_input" and the
    # reason in ``message``; the others are identified as usual.
    if magnitudes is not None and len(magnitudes) != len(frames):
        raise InvalidInputError(f"magnitudes has {len(magnitudes)} entries for {len(frames)} frames")
    if threads is not None and int(threads) < 1:
        raise InvalidInputError(f"threads must be at least 1 (or None for all cores), got {threads}")
    nthreads = None if threads is None else int(threads)
    cfg = _config(config, settings)
    # (Chosen for the field and the batch's magnitudes only where nothing was given.)
    cat = resolve_catalog_for(catalog, cam, _pooled(magnitudes) if catalog is None else None, cfg.mag_offset)
    if cam is not None and attitude_hint is None and type(frames) is list:
        # The common batch (lists of float64 arrays) is read by the core without a Python loop;
        # any other form comes back NotImplemented and is converted below, frame by frame.
        res = _starid.identify_many(cat._native, frames, magnitudes, cam, cfg, nthreads)
        if res is not NotImplemented:
            return cast(list[Identification], res)
    xys: list[npt.NDArray[np.float64]] = []
    mags_or_none: list[Optional[npt.NDArray[np.float64]]] = []
    bad: dict[int, str] = {}
    for i, f in enumerate(frames):
        try:
            # float64 (N, 2) arrays as they are (no conversion, no name written unless needed).
            if type(f) is np.ndarray and f.dtype is _F64 and f.ndim == 2 and f.shape[1] == 2:
                a = f
            else:
                a = _xy(f)
            m = None if magnitudes is None else _magnitudes(magnitudes[i], a.shape[0])
        except ValueError as e:
            bad[i] = f"frame {i}: {e}"
            a, m = np.empty((0, 2)), None
        xys.append(a)
        mags_or_none.append(m)
    mags = None if magnitudes is None else mags_or_none
    if cam is None:
        if attitude_hint is not None:
            raise InvalidInputError("an attitude hint needs a known field of view (fov_deg or camera)")
        results = cast(
            list[Identification], identify_unknown_field(catalog, xys, mags_or_none, (w, h), rng, cfg, nthreads)
        )
    elif attitude_hint is not None:
        results = _hinted_batch(
            cat, cam, xys, mags_or_none, attitude_hint, _positive("hint_uncertainty_deg", hint_uncertainty_deg),
            _flag("hint_fallback", hint_fallback), cfg, threads,
        )
    else:
        # Every frame is now a float64 array: the core takes the lists as they are.
        results = cast(list[Identification], _starid.identify_many(cat._native, xys, mags, cam, cfg, nthreads))
    # (A frame the core refuses in a batch is already named by its place: see the native
    # identify_many; the threaded paths name theirs.)
    for i, msg in bad.items():
        f = frames[i]
        results[i] = _invalid(msg, len(f) if isinstance(f, Sized) else 0)
    return results


def _pooled(magnitudes: Optional[Sequence[Any]]) -> Optional[npt.NDArray[np.float64]]:
    """A batch's magnitudes as one array, for the choice of catalogue (None where any is not
    numeric: the frame's own check names it)."""
    if magnitudes is None:
        return None
    try:
        return np.concatenate([np.asarray(m, dtype=np.float64).ravel() for m in magnitudes])
    except (TypeError, ValueError):
        return None


def _image_batch(
    images: Sequence[Any], catalog: CatalogLike, fov_deg: Optional[float], threads: Optional[int], kwargs: dict[str, Any]
) -> list[Identification]:
    """Images read and extracted on a thread pool (the core releases the GIL), then their spots
    identified by the core's batch, one batch per image size; results in input order."""
    if threads is not None and int(threads) < 1:
        raise InvalidInputError(f"threads must be at least 1 (or None for all cores), got {threads}")
    cat = None if catalog is None else resolve_catalog(catalog)

    def named(i: int, message: Any) -> str:
        """``message`` naming image ``i`` (its path, or its place in the batch)."""
        name = os.fspath(images[i]) if isinstance(images[i], (str, os.PathLike)) else f"image {i}"
        return str(message) if str(name) in str(message) else f"{name}: {message}"

    workers = (os.cpu_count() or 1) if threads is None else int(threads)
    # The spots of every image first, then the centroid lists identified as one batch per image
    # size (identify_many): a known camera's images teach the batch their zero point
    # (``learn_zero_point``), and an unknown field's are searched stage by stage together.
    extract_kw = dict(kwargs.pop("extract", None) or {}, dark=kwargs.pop("dark", None), flat=kwargs.pop("flat", None))
    size = kwargs.pop("image_size", None)
    hints = _per_frame_hints(kwargs.get("attitude_hint"), len(images))
    kwargs.setdefault("mag_offset", None)

    def spots(i: int) -> Any:
        try:
            c = extract_centroids(images[i], **extract_kw)
            if size is not None and tuple(float(v) for v in size) != c.image_size:
                raise InvalidInputError(f"image_size {size} differs from the image's {c.image_size}")
            return c
        except (ValueError, OSError, ImportError) as e:
            return named(i, e)

    found = _map_threads(spots, len(images), workers)
    results: list[Optional[Identification]] = [None] * len(images)
    by_size: dict[tuple[float, float], list[int]] = {}
    for i, c in enumerate(found):
        if isinstance(c, str):
            results[i] = _invalid(c, 0)
        else:
            by_size.setdefault(c.image_size, []).append(i)
    for sz, idx in by_size.items():
        cents = [found[i] for i in idx]
        mags = [c.magnitudes if np.isfinite(c.magnitudes).all() else None for c in cents]
        group = dict(kwargs)
        if hints is not None:
            group["attitude_hint"] = [hints[i] for i in idx]
        batch = identify_many(
            [c.xy for c in cents], cat, fov_deg, None if kwargs.get("camera") is not None else sz,
            magnitudes=mags, threads=threads, **group,
        )
        # Images the field as given found nothing in: searched again over the tolerance's range.
        rough = [k for k, r in enumerate(batch) if fov_deg is not None and rough_field_applies(r, fov_deg, kwargs)]
        again = identify_rough_field(
            cat, [cents[k].xy for k in rough], [mags[k] for k in rough], sz, float(fov_deg or 0.0), settings_of(kwargs),
            threads,
        )
        for k, r in zip(rough, again):
            batch[k] = batch[k] if r is None else r
        for i, r in zip(idx, batch):
            if r.status == "invalid_input":
                r = _invalid(named(i, r.message), len(r.ids))
            results[i] = r._with_times(found[i].read_s, found[i].extract_s)
    return cast(list[Identification], results)


def _per_frame_hints(attitude_hint: Any, n: int) -> Optional[list[Any]]:
    """``attitude_hint`` as one hint per frame where it is a list of them (None where it is one
    hint for every frame, or none)."""
    per_frame = isinstance(attitude_hint, (list, tuple)) and len(attitude_hint) == n and not (
        n in (3, 4) and all(isinstance(v, numbers.Real) for v in attitude_hint)
    )
    return list(attitude_hint) if per_frame else None


def _map_threads(fn: Callable[[int], T], n: int, workers: int) -> list[T]:
    """``[fn(0), …, fn(n − 1)]`` on a pool of threads. Ctrl-C cancels the calls not yet begun
    and raises at once, without waiting for the rest of the batch."""
    pool = ThreadPoolExecutor(max_workers=max(1, workers))
    try:
        return list(pool.map(fn, range(n)))
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _hinted_batch(
    cat: Catalog,
    cam: Any,
    xys: list[npt.NDArray[np.float64]],
    mags: list[Optional[npt.NDArray[np.float64]]],
    attitude_hint: Any,
    uncertainty_deg: float,
    fallback: bool,
    cfg: Any,
    threads: Optional[int],
) -> list[Identification]:
    """Frames with attitude hints, identified by the core in parallel (Ctrl-C stops them)."""
    each = _per_frame_hints(attitude_hint, len(xys))
    hints = [None if h is None else _hint(h) for h in (each if each is not None else [attitude_hint] * len(xys))]
    return _starid.identify_hinted_many(cat._native, xys, mags, cam, cfg, hints, uncertainty_deg, fallback, threads)

