"""Star images in: centroid extraction, image readers, identification of a picture, simulated
images.

>>> import starid
>>> img, truth = starid.simulate_image(fov_deg=12.0, image_size=(640, 480), seed=3, hot_pixels=10)
>>> spots = starid.extract_centroids(img)
>>> res = starid.identify(img, fov_deg=12.0)            # image_size comes from the image
>>> res.ok
True
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._args import Identification, IdentifyConfig, _camera, _config, _flag, _whole
from ._catalog import Catalog, CatalogLike, PathLike, catalog_for, resolve_catalog, resolve_catalog_for
from ._centroids import FLAGS, Centroids
from ._errors import InvalidInputError
from ._read import LUMA_WEIGHTS, MAX_IMAGE_PIXELS, _as_image, _load, image_size_of, read_image
from ._simulate import Frame, _frame
from ._solve import identify_centroids
from ._unknown_field import identify_rough_field, stages
from .plot import annotate
from .wcs import wcs, wcs_header

__all__ = ["EXTRACT_DEFAULTS", "FLAGS", "RENDER_DEFAULTS", "Centroids", "ImageIdentification", "extract_centroids", "identify_image", "read_image", "simulate_image"]



@dataclass(frozen=True)
class ImageIdentification:
    """An image's identification (``identification``, whose ids follow ``centroids``) and the
    spots extracted from it."""

    identification: Identification
    centroids: Centroids
    #: The camera given to identify it, if any (its principal point and ``k1`` go into the WCS).
    camera: Optional[Any] = None

    @property
    def ok(self) -> bool:
        """Whether the image was identified."""
        return bool(self.identification.ok)

    def wcs_header(self) -> dict[str, Any]:
        """The FITS WCS keywords (TAN) of the identified image (see :mod:`starid.wcs`)."""
        return wcs_header(self.identification, self.centroids.image_size, self.camera)

    def wcs(self) -> Any:
        """The ``astropy.wcs.WCS`` of the identified image (``pip install 'starid-solver[fits]'``)."""
        return wcs(self.identification, self.centroids.image_size, self.camera)

    def plot(self, image: Union[npt.ArrayLike, PathLike], path: Optional[PathLike] = None, *, catalog: CatalogLike = None, dpi: int = 100) -> Any:
        """The image annotated with this identification (see :func:`starid.plot.annotate`;
        ``pip install 'starid-solver[plot]'``): saved as a PNG of the image's size at ``path`` when given;
        returns the matplotlib figure."""
        return annotate(image, self, path, catalog=catalog, dpi=dpi)


def _calibration_frame(frame: Optional[Union[npt.ArrayLike, PathLike]], name: str) -> Optional[npt.NDArray[np.float32]]:
    """A dark or flat frame (array or file) as the core reads it: float32, C order."""
    if frame is None:
        return None
    pixels = read_image(frame) if isinstance(frame, (str, os.PathLike)) else _as_image(frame, name)
    return np.ascontiguousarray(pixels, dtype=np.float32)


def extract_centroids(
    image: Union[npt.ArrayLike, PathLike],
    *,
    dark: Optional[Union[npt.ArrayLike, PathLike]] = None,
    flat: Optional[Union[npt.ArrayLike, PathLike]] = None,
    threshold_sigma: Optional[float] = None,
    background_block: Optional[int] = None,
    min_pixels: Optional[int] = None,
    max_spots: Optional[int] = None,
    saturation: Optional[float] = None,
    max_elongation: Optional[float] = None,
    drop_flagged: Optional[bool] = None,
    hot_pixel_ratio: Optional[float] = None,
    deblend: Optional[bool] = None,
    filter_sigma_px: Optional[float] = None,
) -> Centroids:
    """The star spots of an image (array or file), brightest first.

    A setting left None takes the core's default (:data:`EXTRACT_DEFAULTS`, listed below);
    ``saturation`` None is no saturation level.

    ``dark`` (a dark or median frame) is subtracted and ``flat`` divided out (normalised to
    its median) before extraction; non-finite pixels (a clipped or masked background) take the
    image's median. Background: block medians of ``background_block`` pixels, interpolated;
    detection ``threshold_sigma`` noise σ above it (σ from the quartiles, or from the pixels
    above a background clipped at zero, as frames whose pipeline removed it have it); hot pixels cleaned first.
    Detection runs on the image smoothed by a Gaussian of ``filter_sigma_px`` (a matched
    filter: a star spread over a few pixels keeps its height where a one-pixel noise spike
    sinks), its threshold in σ of the smoothed image; centroids and fluxes come from the image
    itself. ``filter_sigma_px=0`` detects on the image itself. With ``deblend``, a
    spot with two or three distinct peaks (a close double) is split into one spot per peak,
    flagged ``deblended``.

    >>> import starid
    >>> img, _ = starid.simulate_image(image_size=(320, 240), fov_deg=8.0, seed=1)
    >>> c = starid.extract_centroids(img)
    >>> len(c) > 0, c.xy.shape[1]
    (True, 2)
    """
    t0 = time.perf_counter()
    img = _load(image)
    read_s = time.perf_counter() - t0 if isinstance(image, (str, os.PathLike)) else 0.0
    t1 = time.perf_counter()
    raw: dict[str, Any] = _starid.extract_centroids(
        img,
        _calibration_frame(dark, "dark"),
        _calibration_frame(flat, "flat"),
        _maybe(float, threshold_sigma),
        _maybe(lambda v: _whole("background_block", v), background_block),
        _maybe(lambda v: _whole("min_pixels", v), min_pixels),
        _maybe(lambda v: _whole("max_spots", v), max_spots),
        _maybe(float, saturation),
        _maybe(float, max_elongation),
        _maybe(lambda v: _flag("drop_flagged", v), drop_flagged),
        _maybe(float, hot_pixel_ratio),
        _maybe(lambda v: _flag("deblend", v), deblend),
        _maybe(float, filter_sigma_px),
    )
    return Centroids(
        xy=raw["xy"],
        flux=raw["flux"],
        magnitudes=raw["magnitudes"],
        peak=raw["peak"],
        pixels=raw["pixels"],
        elongation=raw["elongation"],
        flags=raw["flags"],
        image_size=(float(img.shape[1]), float(img.shape[0])),
        background=float(raw["background"]),
        noise_sigma=float(raw["noise_sigma"]),
        hot_pixels=int(raw["hot_pixels"]),
        dropped=int(raw["dropped"]),
        read_s=read_s,
        extract_s=time.perf_counter() - t1,
    )


def identify_image(
    image: Union[npt.ArrayLike, PathLike],
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    *,
    dark: Optional[Union[npt.ArrayLike, PathLike]] = None,
    flat: Optional[Union[npt.ArrayLike, PathLike]] = None,
    extract: Optional[dict[str, Any]] = None,
    **kwargs: Any,
) -> ImageIdentification:
    """Extract an image's spots and identify them: the identification and the centroids.

    The image size comes from the image; the spots' instrument magnitudes are passed with
    ``mag_offset=None`` (their zero point is unknown) unless given. ``extract`` holds
    :func:`extract_centroids` settings; other arguments as :func:`starid.identify`
    (``fov_deg`` omitted: searched in ``fov_range_deg``).
    """
    warm = warm_index(image, catalog, fov_deg, kwargs)
    c = extract_centroids(image, dark=dark, flat=flat, **(extract or {}))
    if warm is not None:
        warm.join()
    size = kwargs.pop("image_size", None)
    if size is not None and tuple(float(v) for v in size) != c.image_size:
        raise InvalidInputError(f"image_size {size} differs from the image's {c.image_size}")
    kwargs.setdefault("mag_offset", None)
    mags = c.magnitudes if np.isfinite(c.magnitudes).all() else None
    if kwargs.get("camera") is not None:
        res = identify_centroids(c.xy, catalog, None, None, mags, **kwargs)
    else:
        res = identify_centroids(c.xy, catalog, fov_deg, c.image_size, mags, **kwargs)
        if fov_deg is not None and rough_field_applies(res, fov_deg, kwargs):
            again = identify_rough_field(catalog, [c.xy], [mags], c.image_size, float(fov_deg), settings_of(kwargs), None)[0]
            res = res if again is None else again
    return ImageIdentification(res._with_times(c.read_s, c.extract_s), c, kwargs.get("camera"))


#: The extraction settings' defaults, as the core writes them (name → value).
EXTRACT_DEFAULTS: dict[str, Any] = dict(_starid.extract_defaults())

#: The image simulator's rendering defaults, as the core writes them (name → value).
RENDER_DEFAULTS: dict[str, Any] = dict(_starid.render_defaults())


def _with_defaults(doc: Optional[str], defaults: dict[str, Any]) -> Optional[str]:
    """``doc`` with the defaults listed before its examples."""
    if doc is None:
        return None
    listed = "\n    Defaults: " + ", ".join(f"``{k}={v!r}``" for k, v in defaults.items()) + ".\n"
    at = doc.find("\n    >>>")
    return doc + listed if at < 0 else doc[:at] + listed + doc[at:]


extract_centroids.__doc__ = _with_defaults(extract_centroids.__doc__, EXTRACT_DEFAULTS)


def _maybe(convert: Any, value: Any) -> Any:
    """``convert(value)``, or None for None (the core's default)."""
    return None if value is None else convert(value)


def warm_index(image: Any, catalog: CatalogLike, fov_deg: Optional[float], kwargs: dict[str, Any]) -> Optional[threading.Thread]:
    """Start loading what identifying ``image`` will need on a thread of its own, while the
    image is read and its spots extracted on this one; join it before identifying. With the
    field known: the catalogue starid chooses for it and its pair index from the disk cache.
    With no field given: the first stage's catalogue and index, then the deep catalogue that
    a narrow field's frame is identified with again (see ``starid._unknown_field``). None
    where what is needed is not known ahead (a range, a hint, a zero point given, which may
    choose a deeper catalogue from the spots). Best effort: the identification reports
    whatever goes wrong."""
    camera = kwargs.get("camera")
    if kwargs.get("fov_range_deg") is not None:
        return None
    if kwargs.get("attitude_hint") is not None or kwargs.get("mag_offset") is not None:
        return None
    if catalog is not None and not isinstance(catalog, Catalog):
        return None
    size = camera.image_size if camera is not None else image_size_of(image)
    if size is None:
        return None

    def load() -> None:
        try:
            if camera is None and fov_deg is None:
                _, hi, first, _, _ = stages(catalog, None, size)[0]
                first()._native.index_info(_camera(None, hi, size).diagonal_fov_deg, False)
                if catalog is None:
                    Catalog.deep()
                return
            cam = camera if camera is not None else _camera(None, fov_deg, size)
            cat = catalog if catalog is not None else catalog_for(cam.fov_deg, cam.image_size)
            cat._native.index_info(cam.diagonal_fov_deg, False)
        except Exception:  # the identification meets it again and reports it
            pass

    thread = threading.Thread(target=load, name="starid-warm-index", daemon=True)
    thread.start()
    return thread


def rough_field_applies(res: Identification, fov_deg: Optional[float], kwargs: dict[str, Any]) -> bool:
    """Whether an image's field as given found nothing it might find in the tolerance's range: a
    lens's nominal focal length or a sensor's crop can put a photograph's field several percent
    off, where the search about the given field no longer reaches (see ``identify_rough_field``)."""
    return (
        not res.ok
        and res.status in ("no_match", "search_limit")
        and fov_deg is not None
        and kwargs.get("attitude_hint") is None
        and kwargs.get("camera") is None
    )


def settings_of(kwargs: dict[str, Any]) -> Any:
    """The native settings of an image call's keyword arguments."""
    names = set(IdentifyConfig.names())
    return _config(kwargs.get("config"), {k: v for k, v in kwargs.items() if k in names})


def simulate_image(
    catalog: CatalogLike = None,
    fov_deg: float = 12.0,
    image_size: tuple[float, float] = (1024, 768),
    *,
    seed: int = 0,
    mag_limit: Optional[float] = 6.0,
    false_stars: int = 0,
    psf_sigma_px: Optional[float] = None,
    zero_point_e: Optional[float] = None,
    background_e: Optional[float] = None,
    gradient_e: Optional[float] = None,
    read_noise_e: Optional[float] = None,
    hot_pixels: Optional[int] = None,
    hot_pixel_e: Optional[float] = None,
    trail: Optional[tuple[float, float, float, float, float]] = None,
    full_well_e: Optional[float] = None,
    gain_e_per_dn: Optional[float] = None,
    bits: Optional[int] = None,
    clip_background: Optional[bool] = None,
    foreground: Optional[float] = None,
) -> tuple[npt.NDArray[Any], Frame]:
    """A simulated frame rendered to pixels, with its truth: pixel-integrated Gaussian PSFs
    (``psf_sigma_px``), a star of magnitude 0 giving ``zero_point_e`` electrons, sky
    ``background_e`` with a left-to-right ``gradient_e``, hot pixels, a satellite ``trail``
    ``(x0, y0, x1, y1, electrons per pixel)``, Poisson and read noise, saturation at
    ``full_well_e``, ``bits``-bit quantisation with ``gain_e_per_dn``. With
    ``clip_background``, the sky is subtracted before quantisation and what falls below it
    reads 0, as in frames whose pipeline removed the background. ``foreground`` (a share of the
    width, below 1) covers the right of the frame with a lit, textured foreground, its edge
    ragged, as branches or a roof against a town-lit sky: the stars behind it are hidden and
    its texture makes spots that are not stars. A rendering setting left None takes the core's
    default (:data:`RENDER_DEFAULTS`, listed below).

    The image holds the digital numbers a sensor gives: uint16 for 16 bits, uint8 for 8, so
    that Pillow or astropy save it as it is (``PIL.Image.fromarray(img).save("frame.png")``
    writes a 16-bit PNG).
    """
    cam = _camera(None, fov_deg, image_size)
    cat = resolve_catalog_for(catalog, cam)
    tr = None if trail is None else ((float(trail[0]), float(trail[1]), float(trail[2]), float(trail[3])), float(trail[4]))
    img, d = _starid.simulate_image(
        cat._native, cam, _whole("seed", seed, 2**64 - 1), _maybe(float, mag_limit),
        _whole("false_stars", false_stars),
        _maybe(float, psf_sigma_px), _maybe(float, zero_point_e), _maybe(float, background_e),
        _maybe(float, gradient_e), _maybe(float, read_noise_e),
        _maybe(lambda v: _whole("hot_pixels", v), hot_pixels), _maybe(float, hot_pixel_e), tr,
        _maybe(float, full_well_e), _maybe(float, gain_e_per_dn),
        _maybe(lambda v: _whole("bits", v, 64), bits),
        _maybe(lambda v: _flag("clip_background", v), clip_background),
        _maybe(float, foreground),
    )
    w, h = cam.image_size
    frame: Frame = _frame(d, cam.fov_deg, (w, h), seed)
    # The renderer's values are whole numbers within the bit depth: the integer type is exact.
    depth = RENDER_DEFAULTS["bits"] if bits is None else int(bits)
    return img.astype(np.uint8 if depth == 8 else np.uint16), frame


simulate_image.__doc__ = _with_defaults(simulate_image.__doc__, RENDER_DEFAULTS)

