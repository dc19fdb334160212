"""A field of view not given: searched in stages, band by band, brightest spots first.

Most frames are found from their few brightest spots, as pattern-hash solvers find them: a
stage searches the frames still unidentified for a focal length in one band of fields of view,
with a bundled catalogue about as deep as those spots in a field of that band, on the brightest
:data:`STAGE_SPOTS` spots and a small pair budget. A frame found so is identified again with
all its spots at the field found (the catalogue chosen for that field, or the one given), and
counts only if that identification passes too. The last stage searches the range (by default
:data:`DEFAULT_FOV_RANGE_DEG`) with every spot and the configured budget, as one search would.

The false-match bound is shared among the stages (a union bound): each search, and each
identification again, is held to ``max_false_match_prob`` over the number of stages.

A single frame the first stage does not identify, on a machine of more than one core, has its
last, full stage begun on a thread of its own beside the other quick stages: what it finds
counts only where they find nothing (the stages' order decides, as when they run in turn), and
it is stopped as soon as one of them identifies the frame. A frame that nothing identifies then
takes the longer of the two, not their sum.

A batch learns its field: the frames no stage identified are searched once more at the field
of view its identified frames agree on (:func:`learned_field`), an estimate within the
configured tolerance, as a batch with the field given searches its frames again at the focal
length it learns. That search takes its share of the bound as a stage does.
"""

from __future__ import annotations

import functools
import os
from typing import Any, Callable, Optional, Sequence, Union, cast

import numpy as np
import numpy.typing as npt

from . import _starid
from ._catalog import Catalog, PathLike, catalog_for, resolve_catalog
from ._errors import InvalidInputError

#: The range searched when neither the field of view nor a range is given (degrees).
DEFAULT_FOV_RANGE_DEG = (8.0, 25.0)

#: Brightest spots a quick stage searches (ten: two bright spots that are not stars, a
#: nebula's knot or a planet, leave the quick stage eight stars to find the field from).
STAGE_SPOTS = 10

#: Catalogue pairs a quick stage may visit per frame (about 0.1 s).
STAGE_PAIRS = 100_000

#: Catalogue pairs the first quick stage may visit where the full stage searches its band
#: after it: a frame of that band that needs more is found there (beside the other quick
#: stages, on more than one core), and a frame of another band waits half as long for it.
COVERED_STAGE_PAIRS = 50_000

#: The quick stages: a band of fields of view (degrees), the depth of the bundled catalogue
#: searched in it (Hp) and how many of the brightest spots, in the order tried. The brightest
#: spots of a field of 4-8 degrees are mostly stars to Hp 6.5-8 (the deeper the catalogue, the
#: more catalogue pairs each triangle meets, so the fewer spots its budget covers); of one of
#: 25-60 degrees, stars to about Hp 5.5.
QUICK_STAGES: "tuple[tuple[tuple[float, float], float, int], ...]" = (
    ((8.0, 25.0), 6.5, STAGE_SPOTS),
    ((4.0, 8.0), 6.5, STAGE_SPOTS),
    ((4.0, 8.0), 7.0, STAGE_SPOTS),
    ((4.0, 8.0), 8.0, 6),
    ((25.0, 60.0), 5.5, STAGE_SPOTS),
)

CatalogLike = Union[Catalog, PathLike, None]
#: A stage: ``(lo, hi, its catalogue, spots or None for all, pair budget or None)``; the
#: catalogue is loaded when the stage runs (a frame found earlier never loads the deeper ones).
Stage = tuple[float, float, Callable[[], Catalog], Optional[int], Optional[int]]


def bundled(depth: float) -> Catalog:
    """The bundled catalogue to Hp ``depth``."""
    return Catalog.default() if depth == 6.5 else Catalog.deep(depth)


def stages(
    catalog: CatalogLike, fov_range: Optional[tuple[float, float]], size: tuple[float, float], full: bool = True
) -> list[Stage]:
    """The stages of a search: ``(lo, hi, catalogue, spots or None for all, pair budget or None
    for the configured one)``, each catalogue a function that loads it. A range given keeps the
    quick stages within it; a catalogue given is searched in every one; ``full=False`` leaves
    out the last, full search. The first quick stage, where the full search covers its band,
    has the smaller budget :data:`COVERED_STAGE_PAIRS`."""
    given = None if catalog is None else resolve_catalog(catalog)
    lo, hi = (0.0, 180.0) if fov_range is None else fov_range
    full_lo, full_hi = DEFAULT_FOV_RANGE_DEG if fov_range is None else fov_range
    out: list[Stage] = []
    seen: "set[tuple[float, float, float]]" = set()
    for (blo, bhi), depth, spots in QUICK_STAGES:
        a, b = max(lo, blo), min(hi, bhi)
        key = (a, b, -1.0 if given is not None else depth)
        if a < b and key not in seen:
            seen.add(key)
            covered = full and not out and full_lo <= a and b <= full_hi
            pairs = COVERED_STAGE_PAIRS if covered else STAGE_PAIRS
            out.append((a, b, _given_or(given, functools.partial(bundled, depth)), spots, pairs))
    if full:
        out.append((full_lo, full_hi, _given_or(given, functools.partial(catalog_for, full_hi, size)), None, None))
    return out


def _given_or(given: Optional[Catalog], load: Callable[[], Catalog]) -> Callable[[], Catalog]:
    """The catalogue given, or ``load`` to load the stage's own when it runs."""
    return load if given is None else functools.partial(_itself, given)


def _itself(catalog: Catalog) -> Catalog:
    return catalog


def _brightest(xy: npt.NDArray[np.float64], mags: Optional[npt.NDArray[np.float64]], k: int) -> npt.NDArray[np.intp]:
    """The ``k`` brightest spots (by magnitude, or the first ``k`` without magnitudes)."""
    if mags is None:
        return np.arange(min(k, len(xy)))
    return np.argsort(mags, kind="stable")[:k]


def _pick(
    mags: Optional[npt.NDArray[np.float64]], picks: Optional[npt.NDArray[np.intp]]
) -> Optional[npt.NDArray[np.float64]]:
    return mags if mags is None or picks is None else mags[picks]


def identify_unknown_field(
    catalog: CatalogLike,
    xys: Sequence[npt.NDArray[np.float64]],
    mags: Sequence[Optional[npt.NDArray[np.float64]]],
    size: tuple[float, float],
    fov_range: Optional[tuple[float, float]],
    cfg: Any,
    threads: Optional[int],
    full: bool = True,
) -> list[Any]:
    """Frames of one sensor with the field of view unknown, identified in stages (see the
    module's notes); results in input order, each frame's last search where none identifies it
    (``full=False``: the quick stages only).

    A frame's ``time_s`` counts all its stages, and ``timeout_s`` binds them together: a frame
    out of time searches no further and reports ``timeout``. Its false-match bound is that of
    the identification that named it times the number of searches (a union bound).

    A batch of at least ``FOCAL_LEARN_MIN_FRAMES`` frames whose identified frames agree on the
    field of view (see :func:`learned_field`) searches the frames no stage identified once more
    at that field, given as an estimate, as a batch with the field given does with the focal
    length it learns."""
    if not cfg.verify:
        raise InvalidInputError(
            "verify=false (raw method answers) needs a known field of view: the focal length is fitted to verified matches"
        )
    plan = stages(catalog, fov_range, size, full)
    if not plan:
        raise InvalidInputError(f"no band of fields of view meets {fov_range}")
    # A batch that may learn its field searches once more: a share of the bound for it too.
    learn = full and len(xys) >= _starid.FOCAL_LEARN_MIN_FRAMES
    searches = len(plan) + int(learn)
    share = cfg.replace(max_false_match_prob=cfg.max_false_match_prob / searches)
    limit: Optional[float] = cfg.timeout_s
    w, h = size
    results: list[Any] = [None] * len(xys)
    spent = [0.0] * len(xys)
    todo = list(range(len(xys)))
    # One frame left after the first stage, with cores to spare: the full stage runs beside the
    # quick ones (see the module's notes). (frame, its search, the frame's time when it began)
    beside: Optional[tuple[int, Any, float]] = None
    for k, (lo, hi, load, spots, budget) in enumerate(plan):
        if beside is not None and k == len(plan) - 1:
            i, search, began = beside
            beside = None
            res = search.result()
            spent[i] = max(spent[i], began + res.time_s)
            results[i] = res
            break
        if limit is not None:
            todo = [i for i in todo if results[i] is None or spent[i] < limit]
        if not todo:
            break
        stage_cfg = share if budget is None else share.replace(max_pairs_visited=min(budget, cfg.max_pairs_visited))
        if limit is not None:
            stage_cfg = stage_cfg.replace(timeout_s=max(limit - spent[i] for i in todo))
        # (A frame of no more spots than the stage takes is searched whole, in its own order:
        # the result's spots are the frame's.)
        picks = [
            None if spots is None or len(xys[i]) <= spots else _brightest(xys[i], mags[i], spots) for i in todo
        ]
        sub_xy = [xys[i] if p is None else xys[i][p] for i, p in zip(todo, picks)]
        cat = load()
        sub_m = [_pick(mags[i], p) for i, p in zip(todo, picks)]
        found = _starid.identify_unknown_fov_many(cat._native, sub_xy, sub_m, w, h, lo, hi, stage_cfg, threads)
        left = []
        for i, p, res in zip(todo, picks, found):
            spent[i] += res.time_s
            if res.ok and p is not None and len(p) < len(xys[i]):
                res = _again(catalog, cat, xys[i], mags[i], res, size, stage_cfg.replace(max_pairs_visited=cfg.max_pairs_visited))
                spent[i] += res.time_s
            results[i] = res
            if not res.ok and res.status != "invalid_input":
                left.append(i)
        todo = left
        if beside is not None and beside[0] not in todo:
            beside[1].cancel()
            beside = None
        alone = len(todo) == 1 and (limit is None or spent[todo[0]] < limit)
        if full and k == 0 and alone and len(plan) > 2 and _cores(threads) > 1:
            beside = _full_stage_beside(plan[-1], todo[0], xys, mags, size, share, limit, spent)
    if beside is not None:
        beside[1].cancel()
    if learn:
        _search_at_learned_field(catalog, xys, mags, size, share, limit, threads, results, spent)
    out_of_time = set() if limit is None else {
        i for i, r in enumerate(results) if not r.ok and r.status != "invalid_input" and spent[i] >= limit
    }
    return [
        r._restated("timeout" if i in out_of_time else None, spent[i], float(searches)) for i, r in enumerate(results)
    ]


#: How close to their median (a fraction) the fields of view of a batch's identified frames
#: lie to agree on it.
FIELD_AGREEMENT = 0.01


def learned_field(results: Sequence[Any]) -> Optional[float]:
    """The field of view (degrees) a batch's identified frames agree on: the median of theirs,
    where at least ``FOCAL_LEARN_MIN_FRAMES`` are identified and two thirds of them lie within
    :data:`FIELD_AGREEMENT` of it; None otherwise (frames of several lenses, or too few)."""
    fovs = [float(r.fov_deg) for r in results if r is not None and r.ok]
    if len(fovs) < _starid.FOCAL_LEARN_MIN_FRAMES:
        return None
    median = float(np.median(fovs))
    agree = sum(abs(f / median - 1.0) <= FIELD_AGREEMENT for f in fovs)
    return median if 3 * agree >= 2 * len(fovs) else None


def _search_at_learned_field(
    catalog: CatalogLike,
    xys: Sequence[npt.NDArray[np.float64]],
    mags: Sequence[Optional[npt.NDArray[np.float64]]],
    size: tuple[float, float],
    share: Any,
    limit: Optional[float],
    threads: Optional[int],
    results: list[Any],
    spent: list[float],
) -> None:
    """The frames no stage identified (and with time left), searched by the core's batch at the
    field the identified frames agree on; a frame it identifies takes that result."""
    left = [
        i for i, r in enumerate(results)
        if r is not None and not r.ok and r.status != "invalid_input" and (limit is None or spent[i] < limit)
    ]
    fov = learned_field(results) if left else None
    if fov is None:
        return
    left_mags = [m for m in (mags[i] for i in left) if m is not None]
    pooled = np.concatenate(left_mags) if left_mags else None
    cat = catalog_for(fov, size, pooled, share.mag_offset) if catalog is None else resolve_catalog(catalog)
    cfg = share if limit is None else share.replace(timeout_s=max(limit - spent[i] for i in left))
    # (A batch's frames have magnitudes or none has: see identify_many.)
    with_mags = left_mags if len(left_mags) == len(left) else None
    again = cast(
        list[Any],
        _starid.identify_many(cat._native, [xys[i] for i in left], with_mags, _starid.Camera(size, fov), cfg, threads),
    )
    for i, res in zip(left, again):
        spent[i] += res.time_s
        if res.ok:
            results[i] = res


def _cores(threads: Optional[int]) -> int:
    """The threads a call may use: ``threads``, or every core this process may run on."""
    if threads is not None:
        return int(threads)
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _full_stage_beside(
    stage: Stage,
    i: int,
    xys: Sequence[npt.NDArray[np.float64]],
    mags: Sequence[Optional[npt.NDArray[np.float64]]],
    size: tuple[float, float],
    share: Any,
    limit: Optional[float],
    spent: list[float],
) -> tuple[int, Any, float]:
    """The last, full stage of frame ``i`` begun on a thread of its own: ``(i, the search, the
    frame's time so far)``."""
    lo, hi, load, _, _ = stage
    stage_cfg = share if limit is None else share.replace(timeout_s=limit - spent[i])
    search = _starid.identify_unknown_fov_start(load()._native, xys[i], mags[i], size[0], size[1], lo, hi, stage_cfg)
    return (i, search, spent[i])


def identify_rough_field(
    catalog: CatalogLike,
    xys: Sequence[npt.NDArray[np.float64]],
    mags: Sequence[Optional[npt.NDArray[np.float64]]],
    size: tuple[float, float],
    fov_deg: float,
    cfg: Any,
    threads: Optional[int],
) -> list[Optional[Any]]:
    """Frames that the field as given (``fov_deg`` within ``fov_tolerance``) did not identify,
    searched again by the quick stages over the fields the tolerance allows: what ``fov_deg``
    can be if it is ``fov_tolerance`` off either way. None for a frame they do not identify
    either (or where the tolerance is 0)."""
    tol = float(cfg.fov_tolerance)
    if not 0.0 < tol < 1.0 or not xys:
        return [None] * len(xys)
    rng = (fov_deg / (1.0 + tol), min(fov_deg / (1.0 - tol), 179.0))
    if not any(max(rng[0], lo) < min(rng[1], hi) for (lo, hi), _, _ in QUICK_STAGES):
        return [None] * len(xys)
    found = identify_unknown_field(catalog, xys, mags, size, rng, cfg, threads, full=False)
    return [r if r.ok else None for r in found]


def _again(
    catalog: CatalogLike,
    searched: Catalog,
    xy: npt.NDArray[np.float64],
    mags: Optional[npt.NDArray[np.float64]],
    found: Any,
    size: tuple[float, float],
    cfg: Any,
) -> Any:
    """A frame found from its brightest spots, identified with all of them at the field found;
    the focal length is then fitted over every matched star (Levenberg-Marquardt) and, where it
    moves, the frame identified once more with it. The result carries the fit's uncertainty."""
    fov = float(found.fov_deg)
    cat = searched if catalog is not None else catalog_for(fov, size, mags, cfg.mag_offset)
    res = _starid.identify(cat._native, xy, mags, _starid.Camera(size, fov), cfg)
    if not res.ok or res.k1 != 0.0:
        return res  # (a lens distortion the focal check found already has its focal length fitted with it)
    matched = res.ids >= 0
    rows = cat._native.rows_of(np.ascontiguousarray(res.ids[matched], dtype=np.int64))
    radec = np.column_stack([cat.ra_deg[rows], cat.dec_deg[rows]])
    fit = _starid.fit_pointing(
        radec, np.ascontiguousarray(xy[matched]), size[0], size[1], res.focal_px, True, False, False, res.mirrored, None
    )
    if fit.converged and abs(fit.fov_deg / fov - 1) > 1e-6:
        again = _starid.identify(cat._native, xy, mags, _starid.Camera(size, fit.fov_deg), cfg)
        res = again if again.ok else res
    sigma = fit.focal_sigma_px if fit.converged else float(found.focal_sigma_px)
    return res._restated(None, res.time_s, 1.0, sigma)
