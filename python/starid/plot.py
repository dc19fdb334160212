"""Pictures out: an image annotated with its identification (``pip install 'starid-solver[plot]'``).

Each spot circled (identified stars with their catalogue id and magnitude, unidentified spots
in another colour), the boresight, arrows to celestial north and east, and a caption with the
pointing, field of view, stars matched and time.

>>> import starid, starid.plot, tempfile, os
>>> img, truth = starid.simulate_image(fov_deg=12.0, image_size=(640, 480), seed=3)
>>> res = starid.identify_image(img, fov_deg=12.0)
>>> out = os.path.join(tempfile.mkdtemp(), "annotated.png")
>>> starid.plot.annotate(img, res, out)  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from ._catalog import CatalogLike, resolve_catalog_of
from ._errors import InvalidInputError
from ._files import write_atomically
from ._args import Identification
from ._read import _load

__all__ = ["annotate", "sky_to_pixel"]

PathLike = Union[str, "os.PathLike[str]"]

#: Colours of identified and unidentified spots.
IDENTIFIED_COLOUR = "#39d353"
UNIDENTIFIED_COLOUR = "#ff6b3d"


def sky_to_pixel(result: Identification, image_size: tuple[float, float], ra_deg: npt.ArrayLike, dec_deg: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Pixel positions ``(N, 2)`` (x right, y down, origin top-left) of sky directions under an
    identified frame's attitude and focal length (ideal camera centred on the sensor; NaN
    behind the camera). Mirrored frames are drawn as the image is: x reversed."""
    if not result.ok or result.rotation_matrix is None:
        raise InvalidInputError("the identification has no solution to project with")
    ra = np.radians(np.atleast_1d(np.asarray(ra_deg, dtype=np.float64)))
    dec = np.radians(np.atleast_1d(np.asarray(dec_deg, dtype=np.float64)))
    v = np.stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)], axis=1)
    cam = v @ np.asarray(result.rotation_matrix).T
    w, h = (float(s) for s in image_size)
    f = float(result.focal_px)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = w / 2 + f * cam[:, 0] / cam[:, 2]
        y = h / 2 + f * cam[:, 1] / cam[:, 2]
    if result.mirrored:
        x = w - x
    out = np.stack([x, y], axis=1)
    out[cam[:, 2] <= 0] = np.nan
    return out


def _stretch(image: npt.NDArray[np.float32]) -> npt.NDArray[np.float64]:
    """Display scaling: background at the 50th percentile, asinh up to the 99.8th."""
    img = np.asarray(image, dtype=np.float64)
    finite = img[np.isfinite(img)]
    if finite.size == 0:
        return np.zeros_like(img)
    lo, hi = np.percentile(finite, [50.0, 99.8])
    span = max(hi - lo, 1e-12)
    return np.asarray(np.arcsinh(np.clip((img - lo) / span, 0.0, None) * 10.0) / np.arcsinh(10.0))


def annotate(
    image: Union[npt.ArrayLike, PathLike],
    result: Any,
    path: Optional[PathLike] = None,
    *,
    catalog: CatalogLike = None,
    xy: Optional[npt.ArrayLike] = None,
    dpi: int = 100,
) -> Any:
    """Draw ``image`` with ``result`` (an :class:`~starid.images.ImageIdentification`, or an
    :class:`~starid.Identification` with the spots ``xy``) and save a PNG at ``path`` (the
    image's own size in pixels at ``dpi``); returns the matplotlib figure.

    ``catalog`` is the one the identification used (None: the bundled one), for the stars'
    magnitudes.
    """
    try:
        import matplotlib

        if path is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle
    except ImportError as e:
        raise ImportError("starid.plot needs matplotlib: pip install 'starid-solver[plot]'") from None
    img = _load(image)
    h, w = img.shape
    if isinstance(result, Identification):
        if xy is None:
            raise InvalidInputError("an Identification needs the spots it identified: pass xy=")
        ident, spots = result, np.asarray(xy, dtype=np.float64)
    elif isinstance(getattr(result, "identification", None), Identification) and hasattr(result, "centroids"):
        # An ImageIdentification (starid.images): the identification and its spots.
        ident, spots = result.identification, result.centroids.xy
    else:
        raise InvalidInputError(f"result must be an ImageIdentification or an Identification, got {type(result).__name__}")
    if spots.ndim != 2 or spots.shape[1] != 2 or len(spots) != len(ident.ids):
        raise InvalidInputError(f"xy must be ({len(ident.ids)}, 2) like the identification's ids, got {spots.shape}")
    if not (isinstance(dpi, int) and 10 <= dpi <= 1000):
        raise InvalidInputError(f"dpi must be an integer in [10, 1000], got {dpi!r}")
    cat = resolve_catalog_of(catalog, ident)
    ids = np.asarray(ident.ids)
    known = ids >= 0
    mags = np.full(len(ids), np.nan)
    if known.any():
        mags[known] = cat.mag[cat._native.rows_of(ids[known])]

    fig = plt.figure(figsize=(w / dpi, h / dpi), dpi=dpi)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.imshow(_stretch(img), cmap="gray", origin="upper", extent=(0, w, h, 0), interpolation="nearest")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_axis_off()
    scale = max(w, h) / 100.0  # sizes relative to the picture
    font = max(5.0, min(11.0, 0.9 * scale * 72 / dpi * 2))
    for k, (x, y) in enumerate(spots):
        colour = IDENTIFIED_COLOUR if known[k] else UNIDENTIFIED_COLOUR
        ax.add_patch(Circle((x, y), 1.2 * scale, fill=False, lw=0.8, color=colour, ls="-" if known[k] else "--"))
        if known[k]:
            ax.text(x + 1.5 * scale, y - 0.6 * scale, f"{ids[k]}  {mags[k]:.1f}", color=colour, fontsize=font)
    if ident.ok:
        ra, dec = float(ident.ra_deg), float(ident.dec_deg)
        cx, cy = w / 2, h / 2
        ax.plot([cx], [cy], marker="+", ms=3 * scale * 72 / dpi * 2, color="#ffd33d", mew=1.0)
        # North and east: a step along each from the boresight, projected.
        step = 0.08 * float(ident.fov_deg)
        cosd = max(math.cos(math.radians(dec)), 1e-6)
        tips = sky_to_pixel(ident, (w, h), [ra, ra + step / cosd], [dec + step if dec + step <= 90 else dec - step, dec])
        for (tx, ty), label in zip(tips, ("N", "E")):
            if not (np.isfinite(tx) and np.isfinite(ty)):
                continue
            sign = -1.0 if (label == "N" and dec + step > 90) else 1.0
            dx, dy = sign * (tx - cx), sign * (ty - cy)
            ax.annotate("", xy=(cx + dx, cy + dy), xytext=(cx, cy), arrowprops={"arrowstyle": "->", "color": "#ffd33d", "lw": 1.0})
            ax.text(cx + 1.15 * dx, cy + 1.15 * dy, label, color="#ffd33d", fontsize=font, ha="center", va="center")
        caption = (
            f"RA {ra:.4f}°  Dec {dec:+.4f}°  roll {float(ident.roll_deg):.3f}°  FOV {float(ident.fov_deg):.3f}°"
            f"{'  mirrored' if ident.mirrored else ''}\n"
            f"{int(ident.n_matched)}/{len(ids)} spots identified ({ident.method}), "
            f"P(false) ≤ {float(ident.false_match_probability):.1e}, {float(ident.time_s) * 1e3:.2f} ms"
        )
    else:
        caption = f"not identified ({ident.status}): {len(ids)} spots, {float(ident.time_s) * 1e3:.2f} ms"
    ax.text(0.01 * w, 0.985 * h, caption, color="white", fontsize=font, va="bottom", ha="left",
            bbox={"facecolor": "black", "alpha": 0.6, "pad": 2, "lw": 0})
    if path is not None:
        inputs = [image] if isinstance(image, (str, os.PathLike)) else []
        write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=dpi), inputs)
        plt.close(fig)
    return fig
