"""Guide-star catalogues: selection by magnitude, rectangle grid or triangular mesh, and metrics.

A star tracker carries a guide catalogue, not the whole sky: few stars, spread evenly, at least
three in every field. :func:`select` builds one with the methods of the guide-star literature,
:func:`metrics` measures how uniform and complete it is, :func:`compare` reproduces the
published comparison of the rectangle grid and the quaternary triangular mesh (QTM), and
:func:`plot` draws the selections on a full-sky map.

Methods of :func:`select` (all keep the input's ids and order; the work is done in Rust):

``"magnitude"`` (``mag_limit``)
    Every star with ``mag <= mag_limit``.
``"doubles"`` (``separation_deg``, ``merge=False``)
    Stars taken brightest first; a star within ``separation_deg`` of a brighter kept star is
    dropped, or with ``merge=True`` merged into it (flux-weighted direction, summed flux, the
    brighter star's id), which is what a tracker that cannot resolve the pair sees.
``"rectangle"`` (``cell_deg=5.0``)
    Right-ascension/declination cells of ``cell_deg`` × ``cell_deg`` (5° gives 72 × 36 = 2592
    cells); the brightest star of each cell.
``"qtm"`` (``level=5``)
    The octahedron's 8 faces projected onto the sphere, split recursively at edge midpoints;
    level ``n`` has ``8·4**(n-1)`` triangles (level 5: 2048). The brightest star per triangle.
``"qtm-weighted"`` (``level=5``)
    The same mesh; per triangle the star of largest weight ``w = -(m + θ)``, ``θ`` its
    angular distance in degrees from the triangle's incentre projected onto the sphere.

>>> import starid, starid.guide
>>> guide = starid.guide.select(starid.Catalog.default(), method="qtm-weighted", level=5)
>>> 1500 < len(guide) <= 2048
True
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._errors import InvalidInputError
from ._files import write_atomically
from ._catalog import Catalog, resolve_catalog

PathLike = Union[str, "os.PathLike[str]"]

METHODS = ("magnitude", "doubles", "rectangle", "qtm", "qtm-weighted")

__all__ = [
    "METHODS",
    "PAPER_TABLE",
    "PaperRow",
    "compare",
    "fov_for_coverage",
    "format_comparison",
    "metrics",
    "nearest_neighbour_deg",
    "plot",
    "qtm_triangle_count",
    "select",
    "stars_per_field",
]


@dataclass(frozen=True)
class PaperRow:
    """One row of the published comparison (contest catalogue, 10° field, 100 000 fields)."""

    method: str
    count: int
    nn_min_deg: float
    nn_mean_deg: float
    nn_std_deg: float
    p_at_least_3: float


#: The guide-star paper's table: rectangle grid of 5° cells (2592 cells) against QTM level 5
#: (2048 triangles), brightest and distance–magnitude weighted, on the 4908-star contest
#: catalogue with a 10° field.
PAPER_TABLE: tuple[PaperRow, ...] = (
    PaperRow("rectangle", 1923, 0.2072, 2.8262, 1.2175, 0.9990),
    PaperRow("qtm", 1800, 0.2276, 2.8718, 1.1347, 0.9988),
    PaperRow("qtm-weighted", 1794, 0.2276, 3.0129, 1.0243, 0.9995),
)


def qtm_triangle_count(level: int) -> int:
    """Number of triangles of QTM level ``level``: ``8 * 4**(level - 1)``.

    >>> qtm_triangle_count(1), qtm_triangle_count(5)
    (8, 2048)
    """
    return int(_starid.guide_qtm_triangle_count(_count("level", level)))


def select(catalog: Union[Catalog, PathLike, None] = None, method: str = "qtm-weighted", **params: Any) -> Catalog:
    """Select guide stars from ``catalog`` (a Catalog, a path, or ``None`` for the bundled one).

    Parameters
    ----------
    method : str
        ``"magnitude"``, ``"doubles"``, ``"rectangle"``, ``"qtm"`` or ``"qtm-weighted"``
        (see the module documentation).
    **params
        ``mag_limit`` (magnitude), ``separation_deg`` and ``merge`` (doubles), ``cell_deg``
        (rectangle, default 5.0), ``level`` (qtm, qtm-weighted; default 5).

    Returns
    -------
    Catalog
        The selected stars, with their catalogue ids, in the input's order.

    Raises
    ------
    ValueError
        For an unknown method, a missing or out-of-range parameter, or an unknown parameter.

    Examples
    --------
    >>> import starid, starid.guide
    >>> cat = starid.Catalog.default()
    >>> rect = starid.guide.select(cat, method="rectangle", cell_deg=5.0)
    >>> len(rect) <= 72 * 36
    True
    >>> bright = starid.guide.select(cat, method="magnitude", mag_limit=4.0)
    >>> bool(bright.mag.max() <= 4.0)
    True
    """
    cat = resolve_catalog(catalog)
    allowed = {
        "magnitude": {"mag_limit"},
        "doubles": {"separation_deg", "merge"},
        "rectangle": {"cell_deg"},
        "qtm": {"level"},
        "qtm-weighted": {"level"},
    }
    if method not in allowed:
        raise InvalidInputError(f"unknown selection method {method!r}; use one of {', '.join(METHODS)}")
    unknown = set(params) - allowed[method]
    if unknown:
        raise InvalidInputError(
            f"method {method!r} takes {sorted(allowed[method])}, not {sorted(unknown)}"
        )
    kwargs: dict[str, Any] = {}
    if method == "magnitude":
        if "mag_limit" not in params:
            raise InvalidInputError("method 'magnitude' needs mag_limit")
        kwargs["mag_limit"] = _finite("mag_limit", params["mag_limit"])
    elif method == "doubles":
        if "separation_deg" not in params:
            raise InvalidInputError("method 'doubles' needs separation_deg")
        kwargs["separation_deg"] = _finite("separation_deg", params["separation_deg"])
        kwargs["merge"] = bool(params.get("merge", False))
    elif method == "rectangle":
        kwargs["cell_deg"] = _finite("cell_deg", params.get("cell_deg", 5.0))
    else:
        level = params.get("level", 5)
        if isinstance(level, bool) or not isinstance(level, (int, np.integer)):
            raise InvalidInputError(f"level must be an integer, got {level!r}")
        if not 1 <= int(level) <= 20:
            raise InvalidInputError(f"the QTM level must be in 1..20 (level 1 is the octahedron's 8 faces), got {level}")
        kwargs["level"] = int(level)
    native = _starid.guide_select(cat._native, method, **kwargs)
    return Catalog._wrap(native, f"{cat.name or 'catalog'} [{method}]")


def metrics(
    catalog: Union[Catalog, PathLike, None] = None,
    fov_deg: float = 10.0,
    trials: int = 100_000,
    *,
    field: str = "circle",
    seed: int = 0,
    k_max: int = 10,
) -> dict[str, Any]:
    """Uniformity and completeness of a guide catalogue.

    Parameters
    ----------
    fov_deg : float
        The field: for ``field="circle"`` the full cone angle, for ``field="square"`` the
        full angle across a side of a square sensor (at a random roll).
    trials : int
        Monte Carlo fields at uniformly random pointings (deterministic for a ``seed``).
    k_max : int
        ``p_at_least`` is reported for k = 1 .. k_max.

    Returns
    -------
    dict
        ``count``; ``nn_min_deg``, ``nn_mean_deg``, ``nn_std_deg`` (nearest-neighbour angle,
        population standard deviation); ``p_at_least_3`` (fraction of fields with >= 3 stars);
        ``p_at_least`` ({k: fraction}); ``stars_per_field`` (array: entry k counts the fields
        holding exactly k stars); ``mean_stars_per_field``; ``trials``; ``pairs`` and
        ``index_bytes`` (the pair index a field of this size needs); ``fov_deg``; ``field``.

    Examples
    --------
    >>> import starid, starid.guide
    >>> m = starid.guide.metrics(starid.Catalog.default(), fov_deg=12.0, trials=10_000)
    >>> sorted(k for k in m if k.startswith("nn_"))
    ['nn_mean_deg', 'nn_min_deg', 'nn_std_deg']
    >>> m["p_at_least_3"] > 0.99
    True
    """
    cat = resolve_catalog(catalog)
    trials = _count("trials", trials)
    out: dict[str, Any] = dict(
        _starid.guide_metrics(cat._native, _finite("fov_deg", fov_deg), trials, _seed(seed), field, _count("k_max", k_max))
    )
    out["stars_per_field"] = np.asarray(out["stars_per_field"], dtype=np.int64)
    out["fov_deg"] = float(fov_deg)
    out["field"] = field
    return out


def stars_per_field(
    catalog: Union[Catalog, PathLike, None] = None,
    fov_deg: float = 10.0,
    trials: int = 100_000,
    *,
    field: str = "circle",
    seed: int = 0,
) -> npt.NDArray[np.int64]:
    """Monte Carlo histogram of the number of guide stars per field (entry k: fields with k stars).

    >>> import starid, starid.guide
    >>> h = starid.guide.stars_per_field(starid.Catalog.default(), fov_deg=12.0, trials=1000)
    >>> int(h.sum())
    1000
    """
    cat = resolve_catalog(catalog)
    hist = _starid.guide_field_counts(cat._native, _finite("fov_deg", fov_deg), _count("trials", trials), _seed(seed), field)
    return np.asarray(hist, dtype=np.int64)


def nearest_neighbour_deg(catalog: Union[Catalog, PathLike, None] = None) -> npt.NDArray[np.float64]:
    """Angle in degrees from each star to its nearest neighbour in the catalogue.

    >>> import starid, starid.guide
    >>> cat = starid.Catalog([1, 2, 3], [0.0, 1.0, 10.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    >>> starid.guide.nearest_neighbour_deg(cat).round(6).tolist()
    [1.0, 1.0, 9.0]
    """
    cat = resolve_catalog(catalog)
    return np.asarray(_starid.guide_nearest_neighbours(cat._native))


def fov_for_coverage(
    catalog: Union[Catalog, PathLike, None] = None,
    p: float = 0.999,
    k: int = 3,
    *,
    field: str = "circle",
    trials: int = 100_000,
    seed: int = 0,
    lo_deg: float = 1.0,
    hi_deg: float = 90.0,
    tol_deg: float = 0.01,
) -> float:
    """The smallest field (degrees) in which a fraction ``p`` of random pointings holds at
    least ``k`` guide stars, by bisection over the Monte Carlo (same pointings at every step).

    Raises ``ValueError`` when even ``hi_deg`` does not reach ``p``.

    >>> import starid, starid.guide
    >>> fov = starid.guide.fov_for_coverage(starid.Catalog.default(), p=0.99, trials=5_000)
    >>> 5.0 < fov < 15.0
    True
    """
    cat = resolve_catalog(catalog)
    return float(
        _starid.guide_fov_for_coverage(
            cat._native,
            _finite("p", p),
            _count("k", k),
            field,
            _count("trials", trials),
            _seed(seed),
            _finite("lo_deg", lo_deg),
            _finite("hi_deg", hi_deg),
            _finite("tol_deg", tol_deg),
        )
    )


def compare(
    catalog: Union[Catalog, PathLike, None] = None,
    *,
    fov_deg: float = 10.0,
    trials: int = 100_000,
    level: int = 5,
    cell_deg: float = 5.0,
    field: str = "circle",
    seed: int = 0,
) -> list[dict[str, Any]]:
    """The paper's comparison on ``catalog``: rectangle grid, QTM and weighted QTM, each row
    :func:`metrics` plus ``method``. Pass the contest catalogue (4908 stars) to compare with
    :data:`PAPER_TABLE`; :func:`format_comparison` prints both side by side.

    >>> import starid, starid.guide
    >>> rows = starid.guide.compare(starid.Catalog.default(), trials=2_000)
    >>> [r["method"] for r in rows]
    ['rectangle', 'qtm', 'qtm-weighted']
    """
    cat = resolve_catalog(catalog)
    rows = []
    for method, params in (("rectangle", {"cell_deg": cell_deg}), ("qtm", {"level": level}), ("qtm-weighted", {"level": level})):
        sel = select(cat, method, **params)
        row = metrics(sel, fov_deg, trials, field=field, seed=seed)
        row["method"] = method
        rows.append(row)
    return rows


def format_comparison(rows: Sequence[Mapping[str, Any]], paper: bool = True) -> str:
    """A text table of :func:`compare` rows, each followed by the paper's figures when ``paper``."""
    head = f"{'method':<14} {'source':<8} {'stars':>6} {'nn min':>8} {'nn mean':>8} {'nn std':>8} {'P(>=3)':>8} {'pairs':>8}"
    lines = [head, "-" * len(head)]
    published = {r.method: r for r in PAPER_TABLE}
    for row in rows:
        lines.append(
            f"{row['method']:<14} {'starid':<8} {row['count']:>6d} {row['nn_min_deg']:>7.4f}° {row['nn_mean_deg']:>7.4f}° "
            f"{row['nn_std_deg']:>7.4f}° {100 * row['p_at_least_3']:>7.2f}% {row['pairs']:>8d}"
        )
        ref = published.get(row["method"])
        if paper and ref is not None:
            lines.append(
                f"{'':<14} {'paper':<8} {ref.count:>6d} {ref.nn_min_deg:>7.4f}° {ref.nn_mean_deg:>7.4f}° "
                f"{ref.nn_std_deg:>7.4f}° {100 * ref.p_at_least_3:>7.2f}% {'':>8}"
            )
    return "\n".join(lines)


def plot(
    selections: Mapping[str, Catalog],
    path: PathLike,
    *,
    title: Optional[str] = None,
    dpi: int = 120,
) -> None:
    """Write a PNG of full-sky Mollweide maps, one panel per selection (needs matplotlib:
    ``pip install 'starid-solver[plot]'``).

    >>> import starid, starid.guide, tempfile, os
    >>> sel = {"rectangle": starid.guide.select(None, "rectangle")}
    >>> path = os.path.join(tempfile.mkdtemp(), "guide.png")
    >>> starid.guide.plot(sel, path)  # doctest: +SKIP
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("starid.guide.plot needs matplotlib: pip install 'starid-solver[plot]'") from None
    if not selections:
        raise InvalidInputError("nothing to plot: pass at least one selection")
    n = len(selections)
    fig = plt.figure(figsize=(7.5, 3.9 * n))
    for i, (name, cat) in enumerate(selections.items()):
        ax = fig.add_subplot(n, 1, i + 1, projection="mollweide")
        # Astronomical convention: RA grows to the left.
        ra = np.radians(cat.ra_deg)
        x = -np.where(ra > np.pi, ra - 2 * np.pi, ra)
        size = np.clip(6.0 - cat.mag, 0.3, 6.0) ** 1.5
        ax.scatter(x, np.radians(cat.dec_deg), s=size, c="k", linewidths=0)
        ticks = np.arange(-150, 151, 30)
        ax.set_xticks(np.radians(ticks))
        ax.set_xticklabels([f"{((-t) % 360) // 15}h" for t in ticks], fontsize=7)
        ax.grid(True, lw=0.3)
        ax.set_title(f"{name}: {len(cat)} stars", fontsize=10)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=dpi))
    plt.close(fig)


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(v):
        raise InvalidInputError(f"{name} must be finite, got {v}")
    return v


#: Most Monte Carlo fields one call draws (about 10 s of work on one core; the core's limit).
MAX_TRIALS: int = _starid.GUIDE_MAX_TRIALS


def _count(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidInputError(f"{name} must be an integer, got {value!r}")
    if value < 1:
        raise InvalidInputError(f"{name} must be >= 1, got {value}")
    if name == "trials" and value > MAX_TRIALS:
        raise InvalidInputError(f"trials must be at most {MAX_TRIALS}, got {value}")
    return int(value)


def _seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**64:
        raise InvalidInputError(f"seed must be an integer in [0, 2**64), got {seed!r}")
    return int(seed)
