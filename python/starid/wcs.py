"""FITS WCS out: place an identified image on the sky (``pip install 'starid-solver[fits]'``).

The TAN projection of the identified attitude and focal length. FITS counts pixels from 1 at
the centre of the first pixel, starid from 0 at its corner, so FITS ``(X, Y) = (x + 0.5,
y + 0.5)`` exactly. Astropy, ds9 and other astronomy tools read the header:

>>> import starid
>>> img, truth = starid.simulate_image(fov_deg=12.0, image_size=(640, 480), seed=3)
>>> res = starid.identify_image(img, fov_deg=12.0)
>>> h = starid.wcs.wcs_header(res.identification, (640, 480))
>>> h["CTYPE1"], h["CTYPE2"]
('RA---TAN', 'DEC--TAN')
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from ._errors import InvalidInputError

__all__ = ["wcs", "wcs_header"]


def _camera_terms(solution: Any, camera: Any, w: float, h: float) -> tuple[float, float, float, float]:
    """Focal length, principal point (in the image's own pixels) and ``k1`` of the solution's
    camera: a fit's own, else the camera given (with the focal length and distortion the focal
    check found, if it did), else the identification's focal length and distortion at the sensor
    centre."""
    if hasattr(solution, "principal_point_px"):  # a PointingFit: already in the image's pixels
        cx, cy = solution.principal_point_px
        return float(solution.focal_px), float(cx), float(cy), float(solution.k1)
    if camera is not None:
        cx, cy = camera.principal_point
        # The focal length the focal check found, where it replaced the camera's (its 1 sigma
        # is then a number).
        f = camera.focal_length_px
        if math.isfinite(getattr(solution, "focal_sigma_px", math.nan)):
            f = solution.focal_px
        # The distortion the focal check found, where it replaced the camera's (else the same).
        k1 = getattr(solution, "k1", camera.k1) if math.isfinite(getattr(solution, "focal_sigma_px", math.nan)) else camera.k1
        # A mirrored frame is seen by the camera with x reversed (x -> W - x).
        return float(f), float(w - cx if solution.mirrored else cx), float(cy), float(k1)
    # An identification knows its camera's principal point (the sensor centre unless a camera
    # said otherwise).
    cx, cy = getattr(solution, "principal_point", (math.nan, math.nan))
    if not (math.isfinite(cx) and math.isfinite(cy)):
        cx, cy = w / 2, h / 2
    elif solution.mirrored:
        cx = w - cx
    return float(solution.focal_px), float(cx), float(cy), float(getattr(solution, "k1", 0.0))


def wcs_header(solution: Any, image_size: tuple[float, float], camera: Optional[Any] = None) -> dict[str, Any]:
    """The WCS keywords of an identified frame of ``image_size`` (width, height) pixels, as a
    dict (``astropy.io.fits.Header(wcs_header(...))`` makes a header of it).

    ``solution`` is an :class:`~starid.Identification` or a :class:`starid.pointing.PointingFit`
    (whose fitted focal length, principal point and ``k1`` are used). ``camera``, a
    :class:`starid.Camera`, gives the principal point and ``k1`` of an identification made with
    it; by default the principal point is the sensor centre. TAN projection; with radial
    distortion (``k1`` not 0), ``RA---TAN-SIP`` with the SIP polynomials of starid's model
    (pixel = c + f (u, v)(1 + k1 (u² + v²))): ``A``/``B`` to order 5 (distorted → ideal,
    the series inverse) and ``AP``/``BP`` to order 3 (ideal → distorted, exact).
    """
    if (hasattr(solution, "ok") and not solution.ok) or getattr(solution, "rotation_matrix", None) is None:
        raise InvalidInputError("the identification has no solution to describe")
    w, h = (float(v) for v in image_size)
    if not (w >= 1 and h >= 1 and math.isfinite(w) and math.isfinite(h)):
        raise InvalidInputError(f"image_size must be positive, got {image_size!r}")
    f, cx, cy, k1 = _camera_terms(solution, camera, w, h)
    if not (math.isfinite(f) and f > 0):
        raise InvalidInputError(f"the solution has no focal length (got {f})")
    r = np.asarray(solution.rotation_matrix)
    x_axis, y_axis = r[0], r[1]  # camera axes in ICRS
    # The reference point is the optical axis (the principal point), where the camera's +z is.
    z = r[2]
    ra = math.atan2(z[1], z[0]) % (2 * math.pi)
    dec = math.asin(max(-1.0, min(1.0, z[2])))
    east = np.array([-math.sin(ra), math.cos(ra), 0.0])
    north = np.array([-math.sin(dec) * math.cos(ra), -math.sin(dec) * math.sin(ra), math.cos(dec)])
    # A camera direction (u, v, 1) has standard coordinates (u X·e + v Y·e, u X·n + v Y·n).
    sign = -1.0 if solution.mirrored else 1.0  # a mirrored frame reads x reversed
    scale = math.degrees(1.0) / f
    cd = scale * np.array([[sign * x_axis @ east, y_axis @ east], [sign * x_axis @ north, y_axis @ north]])
    header: dict[str, Any] = {
        "WCSAXES": 2,
        "CTYPE1": "RA---TAN",
        "CTYPE2": "DEC--TAN",
        "CUNIT1": "deg",
        "CUNIT2": "deg",
        "CRPIX1": cx + 0.5,
        "CRPIX2": cy + 0.5,
        "CRVAL1": math.degrees(ra),
        "CRVAL2": math.degrees(dec),
        "CD1_1": float(cd[0, 0]),
        "CD1_2": float(cd[0, 1]),
        "CD2_1": float(cd[1, 0]),
        "CD2_2": float(cd[1, 1]),
        "RADESYS": "ICRS",
        "IMAGEW": int(round(w)),
        "IMAGEH": int(round(h)),
    }
    if k1 != 0.0:
        header.update(_sip(k1, f))
    return header


def _sip(k1: float, f: float) -> dict[str, Any]:
    """SIP terms of the radial model on pixel offsets (x, y) from the principal point, with
    ρ² = (x² + y²) / f²: ideal = distorted (1 − k1 ρ² + 3 k1² ρ⁴ + ...), distorted = ideal
    (1 + k1 ρ_ideal²)."""
    a3 = -k1 / f**2
    a5 = 3 * k1**2 / f**4
    terms: dict[str, Any] = {"CTYPE1": "RA---TAN-SIP", "CTYPE2": "DEC--TAN-SIP", "A_ORDER": 5, "B_ORDER": 5, "AP_ORDER": 3, "BP_ORDER": 3}
    # x (x² + y²) and x (x² + y²)²; B the same with x and y exchanged.
    for (p, q), c in {(3, 0): a3, (1, 2): a3, (5, 0): a5, (3, 2): 2 * a5, (1, 4): a5}.items():
        terms[f"A_{p}_{q}"] = c
        terms[f"B_{q}_{p}"] = c
    for (p, q), c in {(3, 0): k1 / f**2, (1, 2): k1 / f**2}.items():
        terms[f"AP_{p}_{q}"] = c
        terms[f"BP_{q}_{p}"] = c
    return terms


def wcs(solution: Any, image_size: tuple[float, float], camera: Optional[Any] = None) -> Any:
    """An ``astropy.wcs.WCS`` of the identified frame (see :func:`wcs_header`)."""
    try:
        from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
        from astropy.wcs import WCS  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError as e:
        raise ImportError("a WCS object needs astropy: pip install 'starid-solver[fits]'") from None
    return WCS(fits.Header(wcs_header(solution, image_size, camera)))
