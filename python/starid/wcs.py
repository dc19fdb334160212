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

from ._args import Camera
from ._errors import InvalidInputError

__all__ = ["wcs", "wcs_header"]


def _camera_terms(solution: Any, camera: Any, w: float, h: float) -> tuple[float, float, float, float, tuple[float, float, float, float]]:
    """Focal length, principal point (in the image's own pixels), ``k1`` and the distortion beyond
    it (``k2, k3, p1, p2``) of the solution's camera: a fit's own, else the camera given (with the
    focal length and distortion the focal check found, if it did), else the identification's
    camera."""
    if hasattr(solution, "principal_point_px"):  # a PointingFit: already in the image's pixels
        cx, cy = solution.principal_point_px
        return float(solution.focal_px), float(cx), float(cy), float(solution.k1), (0.0, 0.0, 0.0, 0.0)
    if camera is None:
        camera = getattr(solution, "camera", None)
        if camera is None:  # no focal length known: the sensor centre, the reported values
            return float(solution.focal_px), w / 2, h / 2, float(getattr(solution, "k1", 0.0)), (0.0, 0.0, 0.0, 0.0)
        checked = True
    else:
        # The focal length and k1 the focal check found, where they replaced the camera's (its
        # 1 sigma is then a number).
        checked = math.isfinite(getattr(solution, "focal_sigma_px", math.nan))
    cx, cy = camera.principal_point
    f = solution.focal_px if checked else camera.focal_length_px
    k1 = getattr(solution, "k1", camera.k1) if checked else camera.k1
    higher = (float(camera.k2), float(camera.k3), float(camera.p1), float(camera.p2))
    # A mirrored frame is seen by the camera with x reversed (x -> W - x).
    return float(f), float(w - cx if solution.mirrored else cx), float(cy), float(k1), higher


def wcs_header(solution: Any, image_size: tuple[float, float], camera: Optional[Any] = None) -> dict[str, Any]:
    """The WCS keywords of an identified frame of ``image_size`` (width, height) pixels, as a
    dict (``astropy.io.fits.Header(wcs_header(...))`` makes a header of it).

    ``solution`` is an :class:`~starid.Identification` or a :class:`starid.pointing.PointingFit`
    (whose fitted focal length, principal point and ``k1`` are used). ``camera``, a
    :class:`starid.Camera`, gives the principal point and ``k1`` of an identification made with
    it; by default the identification's own camera. TAN projection; with radial distortion
    ``k1`` alone, ``RA---TAN-SIP`` with the SIP polynomials of starid's model (pixel = c + f
    (u, v)(1 + k1 (u² + v²))): ``A``/``B`` to order 5 (distorted → ideal, the series inverse)
    and ``AP``/``BP`` to order 3 (ideal → distorted, exact); with the full Brown–Conrady model
    of a calibrated camera (``k2``, ``k3``, ``p1``, ``p2``), SIP polynomials of order 5 fitted
    to it over the sensor.
    """
    if (hasattr(solution, "ok") and not solution.ok) or getattr(solution, "rotation_matrix", None) is None:
        raise InvalidInputError("the identification has no solution to describe")
    w, h = (float(v) for v in image_size)
    if not (w >= 1 and h >= 1 and math.isfinite(w) and math.isfinite(h)):
        raise InvalidInputError(f"image_size must be positive, got {image_size!r}")
    f, cx, cy, k1, higher = _camera_terms(solution, camera, w, h)
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
    if any(higher):
        header.update(_sip_fitted(f, cx, cy, k1, higher, w, h, bool(solution.mirrored)))
    elif k1 != 0.0:
        header.update(_sip(k1, f))
    return header


#: Orders of the SIP polynomials tried for a camera with distortion beyond ``k1``: the lowest
#: whose fit is within :data:`SIP_FIT_TOLERANCE_PX` everywhere on the sensor is written.
SIP_FIT_ORDERS = (5, 7, 9)
#: Largest error of a fitted SIP polynomial on the sensor, pixels.
SIP_FIT_TOLERANCE_PX = 0.005


def _sip_fitted(f: float, cx: float, cy: float, k1: float, higher: tuple[float, float, float, float], w: float, h: float, mirrored: bool) -> dict[str, Any]:
    """SIP terms of the full Brown–Conrady model, fitted by least squares over a grid that
    covers the sensor (and a margin): ``A``/``B`` from distorted pixel offsets to ideal ones,
    ``AP``/``BP`` back, of the lowest order in :data:`SIP_FIT_ORDERS` that is within
    :data:`SIP_FIT_TOLERANCE_PX` of the model (the highest otherwise), in the image's own pixels
    (a mirrored frame's x reversed)."""
    k2, k3, p1, p2 = higher
    cam_cx = w - cx if mirrored else cx
    cam = Camera((w, h), focal_length_px=f, principal_point=(cam_cx, cy), k1=k1, k2=k2, k3=k3, p1=p1, p2=p2)
    gx, gy = np.meshgrid(np.linspace(-0.05 * w, 1.05 * w, 41), np.linspace(-0.05 * h, 1.05 * h, 41))
    pix = np.column_stack([gx.ravel(), gy.ravel()])
    v = cam.unproject(pix)
    ideal = f * v[:, :2] / v[:, 2:3]  # ideal offsets from the principal point, camera pixels
    dist = pix - np.array([cam_cx, cy])
    sign = np.array([-1.0 if mirrored else 1.0, 1.0])
    ideal, dist = ideal * sign, dist * sign  # the image's own pixel offsets

    def fit(src: Any, dst: Any, terms: list[tuple[int, int]]) -> tuple[Any, Any, float]:
        u, vv = src[:, 0] / f, src[:, 1] / f  # normalised for conditioning
        design = np.column_stack([u**p * vv**q for p, q in terms])
        coef, *_ = np.linalg.lstsq(design, (dst - src) / f, rcond=None)
        worst = float(np.abs(design @ coef - (dst - src) / f).max() * f)
        scale = np.array([f ** (1 - p - q) for p, q in terms])
        return coef[:, 0] * scale, coef[:, 1] * scale, worst

    for order in SIP_FIT_ORDERS:
        terms = [(p, n - p) for n in range(2, order + 1) for p in range(n, -1, -1)]
        a, b, worst_a = fit(dist, ideal, terms)
        ap, bp, worst_ap = fit(ideal, dist, terms)
        if max(worst_a, worst_ap) <= SIP_FIT_TOLERANCE_PX:
            break
    out: dict[str, Any] = {"CTYPE1": "RA---TAN-SIP", "CTYPE2": "DEC--TAN-SIP", "A_ORDER": order, "B_ORDER": order, "AP_ORDER": order, "BP_ORDER": order}
    for (p, q), ca, cb, cap, cbp in zip(terms, a, b, ap, bp):
        out[f"A_{p}_{q}"], out[f"B_{p}_{q}"] = float(ca), float(cb)
        out[f"AP_{p}_{q}"], out[f"BP_{p}_{q}"] = float(cap), float(cbp)
    return out


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
