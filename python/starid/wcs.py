"""FITS WCS out: place an identified image on the sky (``pip install starid[fits]``).

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
from typing import Any

import numpy as np

from ._errors import InvalidInputError
from ._identify import Identification

__all__ = ["wcs", "wcs_header"]


def wcs_header(result: Identification, image_size: tuple[float, float]) -> dict[str, Any]:
    """The WCS keywords (TAN) of an identified frame of ``image_size`` (width, height) pixels,
    as a dict (``astropy.io.fits.Header(wcs_header(...))`` makes a header of it). The principal
    point is the sensor centre, as identification assumes."""
    if not result.ok or result.rotation_matrix is None:
        raise InvalidInputError("the identification has no solution to describe")
    w, h = (float(v) for v in image_size)
    if not (w >= 1 and h >= 1 and math.isfinite(w) and math.isfinite(h)):
        raise InvalidInputError(f"image_size must be positive, got {image_size!r}")
    r = np.asarray(result.rotation_matrix)
    x_axis, y_axis = r[0], r[1]  # camera axes in ICRS
    ra, dec = math.radians(result.ra_deg), math.radians(result.dec_deg)
    east = np.array([-math.sin(ra), math.cos(ra), 0.0])
    north = np.array([-math.sin(dec) * math.cos(ra), -math.sin(dec) * math.sin(ra), math.cos(dec)])
    f = float(result.focal_px)
    # A camera direction (u, v, 1) has standard coordinates (u X·e + v Y·e, u X·n + v Y·n).
    sign = -1.0 if result.mirrored else 1.0  # a mirrored frame reads x reversed
    scale = math.degrees(1.0) / f
    cd = scale * np.array([[sign * x_axis @ east, y_axis @ east], [sign * x_axis @ north, y_axis @ north]])
    return {
        "WCSAXES": 2,
        "CTYPE1": "RA---TAN",
        "CTYPE2": "DEC--TAN",
        "CUNIT1": "deg",
        "CUNIT2": "deg",
        "CRPIX1": w / 2 + 0.5,
        "CRPIX2": h / 2 + 0.5,
        "CRVAL1": float(result.ra_deg),
        "CRVAL2": float(result.dec_deg),
        "CD1_1": float(cd[0, 0]),
        "CD1_2": float(cd[0, 1]),
        "CD2_1": float(cd[1, 0]),
        "CD2_2": float(cd[1, 1]),
        "RADESYS": "ICRS",
        "IMAGEW": int(round(w)),
        "IMAGEH": int(round(h)),
    }


def wcs(result: Identification, image_size: tuple[float, float]) -> Any:
    """An ``astropy.wcs.WCS`` of the identified frame (see :func:`wcs_header`)."""
    try:
        from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
        from astropy.wcs import WCS  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError as e:
        raise ImportError("a WCS object needs astropy: pip install 'starid[fits]'") from e
    return WCS(fits.Header(wcs_header(result, image_size)))
