"""Pointing and focal length: the boresight from star distances, attitude and camera refinement,
the precision that follows from the stars' geometry, and the choice of stars that gives the best.

The questions come from the three-star boresight problem. A star at distance ``a`` (pixels) from
the principal point of a pinhole camera of focal length ``f`` lies ``atan(a / f)`` from the
boresight, so each star's distance puts the boresight on a cone around the star:

- :func:`boresight_from_distances`: the boresight (and ``f`` when unknown) from three or more
  stars' RA/Dec and distances alone; every solution, best supported first, flagged
  ``ambiguous`` (another solution fits as well: collinear images have a mirror solution, and with
  ``f`` unknown three stars can have several exact ones) or ``degenerate`` (a direction is not
  determined: collinear images through the principal point; with ``f`` unknown, images on a
  circle through the principal point).
- :func:`fit_pointing` / :func:`refine`: Levenberg–Marquardt over the attitude and the focal
  length, optionally the principal point and the radial distortion ``k1``, over all matched
  stars, with the covariance of the estimate; from an identification or from RA/Dec + pixels.
- :func:`predicted_covariance`, :func:`choose_stars`, :func:`monte_carlo`: the precision of the
  distance solution for a set of image positions, the stars that maximise it, and a Monte Carlo
  check of the prediction.

Conventions: pixels x right, y down, origin at the top-left corner, principal point at
``(W/2, H/2)`` unless fitted; boresight covariances are in radians along the camera's x and y
axes (or the local east and north for :class:`BoresightSolution`).
"""

from __future__ import annotations

import math
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._errors import InvalidInputError
from ._catalog import Catalog, resolve_catalog, resolve_catalog_of
from ._args import Camera, Identification, _image_size, _xy

__all__ = [
    "BoresightSolution",
    "PointingFit",
    "boresight_from_distances",
    "choose_stars",
    "fit_pointing",
    "monte_carlo",
    "predicted_covariance",
    "refine",
]

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0


#: One solution of :func:`boresight_from_distances`: the core's result, read through typed
#: properties (``best`` marks the best supported, which comes first).
BoresightSolution = _starid.BoresightSolution


#: A boresight solution whose distances are missed by more than this (rms, pixels) is flagged
#: ``inconsistent``: far beyond centroid noise, the distances do not belong together.
INCONSISTENT_RMS_PX: float = _starid.INCONSISTENT_RMS_PX


def boresight_from_distances(
    radec_deg: npt.ArrayLike,
    distances_px: npt.ArrayLike,
    focal_px: Optional[float] = None,
    *,
    focal_range_px: Optional[tuple[float, float]] = None,
) -> list[BoresightSolution]:
    """The boresight from stars' RA/Dec and their images' distances from the principal point.

    Parameters
    ----------
    radec_deg : array_like, shape (N, 2), N >= 3
        Right ascension and declination of each star, degrees.
    distances_px : array_like, shape (N,)
        Distance of each star's image from the principal point (sensor centre), pixels.
    focal_px : float, optional
        Focal length in pixels. When omitted it is estimated with the boresight (starts derived
        from the feasible focal interval; every exact solution is found for three stars).
    focal_range_px : (lo, hi), optional
        With ``focal_px`` unknown, keep only solutions whose focal length lies in this range
        (what the optics allow); ``ambiguous`` is then judged among those.

    Returns
    -------
    list of BoresightSolution
        Every distinct solution, best supported first (``best`` True on the first).

    Raises
    ------
    ValueError
        Fewer than 3 stars, mismatched lengths, NaN/negative distances, repeated stars, a bad
        focal length, or no boresight at all.

    Examples
    --------
    >>> import numpy as np, starid.pointing as sp
    >>> stars = [[83.0, -1.0], [86.5, 2.0], [80.5, 3.0]]
    >>> # Distances measured on a 12 deg / 512 px camera pointing at (83.5, 0.5):
    >>> sols = sp.boresight_from_distances(stars, [67.23, 142.72, 166.21], focal_px=2435.68)
    >>> s = sols[0]
    >>> round(s.ra_deg, 1), round(s.dec_deg, 1), s.ambiguous
    (83.5, 0.5, False)
    """
    rd = _radec(radec_deg)
    a = np.ascontiguousarray(distances_px, dtype=np.float64).ravel()
    f = None if focal_px is None else float(focal_px)
    rng = None
    if focal_range_px is not None:
        try:
            lo, hi = (float(v) for v in focal_range_px)
        except (TypeError, ValueError) as e:
            raise InvalidInputError(f"focal_range_px must be a pair (lo, hi), got {focal_range_px!r}") from e
        rng = (lo, hi)
    return _starid.boresight_from_distances(rd, a, f, rng)


#: Attitude and camera fitted to matched stars (:func:`fit_pointing`, :func:`refine`): the
#: core's result, read through typed properties.
PointingFit = _starid.PointingFit


def _focal_guess(focal_px: Optional[float], fov_deg: Optional[float], width: float) -> Optional[float]:
    if focal_px is not None and fov_deg is not None:
        raise InvalidInputError("give focal_px or fov_deg, not both")
    if fov_deg is not None:
        return float(Camera((width, width), float(fov_deg)).focal_length_px)
    return None if focal_px is None else float(focal_px)


def fit_pointing(
    radec_deg: npt.ArrayLike,
    xy: npt.ArrayLike,
    image_size: tuple[float, float],
    *,
    focal_px: Optional[float] = None,
    fov_deg: Optional[float] = None,
    fit_focal: bool = True,
    fit_principal_point: bool = False,
    fit_k1: bool = False,
    mirrored: bool = False,
    sigma_px: Optional[float] = None,
) -> PointingFit:
    """Attitude (and camera) from matched stars by Levenberg–Marquardt, with its covariance.

    ``focal_px`` or ``fov_deg`` is the starting (or, with ``fit_focal=False``, the fixed) focal
    length; with neither, it is derived from the stars' pairwise angles. Three stars give the
    attitude with the roll; more give the focal length, principal point and ``k1`` as asked.
    Converges from a field-of-view guess 40 % off.

    Examples
    --------
    >>> import starid, starid.pointing as sp
    >>> frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=4, noise_px=0.1)
    >>> cat = starid.Catalog.default()
    >>> real = frame.true_ids >= 0
    >>> rows = [int(np.flatnonzero(cat.ids == i)[0]) for i in frame.true_ids[real]]
    >>> radec = np.column_stack([cat.ra_deg[rows], cat.dec_deg[rows]])
    >>> fit = sp.fit_pointing(radec, frame.xy[real], (512, 512), fov_deg=12.0 * 1.4)
    >>> abs(fit.fov_deg - 12.0) < 0.01, fit.converged
    (True, True)
    """
    w, h = _image_size(image_size)
    rd = _radec(radec_deg)
    a = _xy(xy)
    f0 = _focal_guess(focal_px, fov_deg, w)
    if not fit_focal and f0 is None:
        raise InvalidInputError("with fit_focal=False the focal length must be given (focal_px or fov_deg)")
    return _starid.fit_pointing(
        rd, a, w, h, f0, bool(fit_focal), bool(fit_principal_point), bool(fit_k1), bool(mirrored),
        None if sigma_px is None else float(sigma_px),
    )


def refine(
    result: Identification,
    xy: npt.ArrayLike,
    catalog: Union[Catalog, str, None] = None,
    image_size: Optional[tuple[float, float]] = None,
    *,
    fit_focal: bool = True,
    fit_principal_point: bool = False,
    fit_k1: bool = False,
    sigma_px: Optional[float] = None,
) -> PointingFit:
    """Refine an identification over all its matched stars: attitude, focal length and, if
    asked, principal point and ``k1``, with the covariance. ``catalog`` must be the one used
    to identify (None, or the result's ``catalog`` name, finds a bundled one); ``image_size``
    the sensor size.

    Examples
    --------
    >>> import starid, starid.pointing as sp
    >>> frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=2, noise_px=0.2)
    >>> res = starid.identify(frame.xy, fov_deg=12.1, image_size=(512, 512))
    >>> fit = sp.refine(res, frame.xy, image_size=(512, 512))
    >>> abs(fit.fov_deg - 12.0) < 0.02
    True
    """
    if not result.ok:
        raise InvalidInputError("the identification has no solution to refine")
    w, h = _image_size(image_size)
    cat = resolve_catalog_of(catalog, result)
    a = _xy(xy)
    if a.shape[0] != len(result.ids):
        raise InvalidInputError(f"xy has {a.shape[0]} rows but the identification has {len(result.ids)} ids")
    matched = result.ids >= 0
    rows = cat._native.rows_of(np.ascontiguousarray(result.ids[matched], dtype=np.int64))
    radec = np.column_stack([cat.ra_deg[rows], cat.dec_deg[rows]])
    return fit_pointing(
        radec,
        a[matched],
        (w, h),
        focal_px=result.focal_px,
        fit_focal=fit_focal,
        fit_principal_point=fit_principal_point,
        fit_k1=fit_k1,
        mirrored=result.mirrored,
        sigma_px=sigma_px,
    )


def _offsets(xy: npt.ArrayLike, image_size: tuple[float, float]) -> npt.NDArray[np.float64]:
    w, h = _image_size(image_size)
    a = _xy(xy)
    return np.ascontiguousarray(a - np.array([w / 2, h / 2]))


def _focal(focal_px: Optional[float], fov_deg: Optional[float], width: float) -> float:
    f = _focal_guess(focal_px, fov_deg, width)
    if f is None:
        raise InvalidInputError("give the camera: focal_px or fov_deg")
    return f


def predicted_covariance(
    xy: npt.ArrayLike,
    image_size: tuple[float, float],
    *,
    focal_px: Optional[float] = None,
    fov_deg: Optional[float] = None,
    sigma_px: float = 0.1,
    fit_focal: bool = False,
) -> dict[str, Any]:
    """Precision of the boresight from the distances of the images at ``xy``.

    Returns a dict: ``covariance`` (camera x, camera y [rad], and focal [px] when
    ``fit_focal``; None when the geometry determines nothing), ``boresight_sigma_arcsec`` and
    ``focal_sigma_px``.

    >>> import starid.pointing as sp
    >>> spread = [[486, 276], [141, 455], [136, 61]]     # edge stars ~120 deg apart
    >>> clustered = [[356, 356], [386, 361], [366, 384]]
    >>> a = sp.predicted_covariance(spread, (512, 512), fov_deg=12)["boresight_sigma_arcsec"]
    >>> b = sp.predicted_covariance(clustered, (512, 512), fov_deg=12)["boresight_sigma_arcsec"]
    >>> a < b
    True
    """
    w, _ = _image_size(image_size)
    f = _focal(focal_px, fov_deg, w)
    c = _starid.predicted_distance_covariance(_offsets(xy, image_size), f, float(sigma_px), bool(fit_focal))
    if c is None:
        return {"covariance": None, "boresight_sigma_arcsec": math.inf, "focal_sigma_px": math.inf}
    return {
        "covariance": c,
        "boresight_sigma_arcsec": float(math.sqrt(c[0, 0] + c[1, 1]) * ARCSEC_PER_RAD),
        "focal_sigma_px": float(math.sqrt(c[2, 2])) if fit_focal else 0.0,
    }


def choose_stars(
    xy: npt.ArrayLike,
    image_size: tuple[float, float],
    count: int = 3,
    *,
    focal_px: Optional[float] = None,
    fov_deg: Optional[float] = None,
    sigma_px: float = 0.1,
    fit_focal: bool = False,
) -> tuple[list[int], float]:
    """The ``count`` stars of a frame whose distances give the most precise boresight.

    Returns the indices (ascending) and the predicted 1σ boresight error in arcsec for
    ``sigma_px`` of centroid noise. The best triple is searched exhaustively (at most 300
    stars), further stars are added greedily.

    >>> import starid.pointing as sp
    >>> xy = [[266, 261], [281, 244], [248, 276], [496, 266], [141, 461], [131, 56]]
    >>> sp.choose_stars(xy, (512, 512), fov_deg=12)[0]
    [3, 4, 5]
    """
    w, _ = _image_size(image_size)
    f = _focal(focal_px, fov_deg, w)
    idx, sigma = _starid.choose_stars(_offsets(xy, image_size), f, int(count), bool(fit_focal))
    return [int(i) for i in idx], float(sigma * sigma_px * ARCSEC_PER_RAD)


def monte_carlo(
    xy: npt.ArrayLike,
    image_size: tuple[float, float],
    *,
    focal_px: Optional[float] = None,
    fov_deg: Optional[float] = None,
    sigma_px: float = 0.1,
    fit_focal: bool = False,
    trials: int = 2000,
    seed: int = 0,
) -> dict[str, Any]:
    """Monte Carlo check of :func:`predicted_covariance`: the images are put on a random sky,
    their distances perturbed ``trials`` times with ``sigma_px`` of noise and solved.

    Returns ``predicted`` and ``sample`` covariances, ``ratio`` (sample/predicted 1σ boresight)
    and ``outliers`` (trials whose best solution was another branch).

    >>> import starid.pointing as sp
    >>> mc = sp.monte_carlo([[486, 276], [141, 455], [136, 61]], (512, 512), fov_deg=12, trials=500)
    >>> 0.85 < mc["ratio"] < 1.15
    True
    """
    w, _ = _image_size(image_size)
    f = _focal(focal_px, fov_deg, w)
    d = dict(_starid.monte_carlo_distances(_offsets(xy, image_size), f, float(sigma_px), bool(fit_focal), int(trials), int(seed)))
    p, s = d["predicted"], d["sample"]
    d["ratio"] = float(math.sqrt((s[0, 0] + s[1, 1]) / (p[0, 0] + p[1, 1])))
    return d


def _radec(radec_deg: npt.ArrayLike) -> npt.NDArray[np.float64]:
    try:
        a = np.ascontiguousarray(radec_deg, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"radec_deg must be an (N, 2) array of RA, Dec in degrees: {e}") from e
    if a.ndim != 2 or a.shape[1] != 2:
        raise InvalidInputError(f"radec_deg must have shape (N, 2) holding (ra_deg, dec_deg), got shape {a.shape}")
    return a
