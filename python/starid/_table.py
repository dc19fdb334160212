"""The per-spot table of an identification: a numpy structured array, a pandas DataFrame, an
astropy Table (with SkyCoord)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

#: The table's columns: pixel position (starid's convention: pixel centres at i + 0.5), the
#: catalogue star's id, position and magnitude (-1 and NaN where unnamed), the spot's own
#: magnitude (NaN without magnitudes) and the angle between the spot's direction and its star.
SPOT_DTYPE = np.dtype(
    [
        ("x", "f8"),
        ("y", "f8"),
        ("catalog_id", "i8"),
        ("ra_deg", "f8"),
        ("dec_deg", "f8"),
        ("catalog_mag", "f8"),
        ("mag", "f8"),
        ("residual_arcsec", "f8"),
    ]
)


def spot_table(res: Any) -> npt.NDArray[Any]:
    """One row per spot of ``res`` (an :class:`~starid.Identification`), in input order."""
    n = len(res.ids)
    out = np.empty(n, dtype=SPOT_DTYPE)
    xy = res.xy
    if len(xy) == n:
        out["x"], out["y"] = xy[:, 0], xy[:, 1]
    else:  # a result that does not know its spots
        out["x"] = out["y"] = np.nan
    out["catalog_id"] = res.ids
    ra, dec, mag = res._star_columns()
    out["ra_deg"], out["dec_deg"], out["catalog_mag"] = ra, dec, mag
    m = res.magnitudes
    out["mag"] = np.nan if m is None else m
    out["residual_arcsec"] = res.residuals_arcsec
    return out


def to_pandas(res: Any) -> Any:
    """:func:`spot_table` as a pandas DataFrame."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError("to_pandas needs pandas: pip install pandas") from None
    return pd.DataFrame(spot_table(res))


def to_astropy(res: Any) -> Any:
    """:func:`spot_table` as an astropy Table, with units and a ``coord`` SkyCoord column of the
    catalogue stars (NaN where unnamed)."""
    try:
        import astropy.units as u  # type: ignore[import-untyped,import-not-found,unused-ignore]
        from astropy.coordinates import SkyCoord  # type: ignore[import-untyped,import-not-found,unused-ignore]
        from astropy.table import Table  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError:
        raise ImportError("to_astropy needs astropy: pip install 'starid-solver[fits]'") from None
    t = Table(spot_table(res))
    for name, unit in (("x", u.pix), ("y", u.pix), ("ra_deg", u.deg), ("dec_deg", u.deg), ("residual_arcsec", u.arcsec)):
        t[name].unit = unit
    t["coord"] = SkyCoord(ra=t["ra_deg"].data * u.deg, dec=t["dec_deg"].data * u.deg, frame="icrs")
    return t
