"""One frame's identification from centroids, by the general path: arguments converted and
checked, then the core's lost-in-space, hinted or unknown-field search. ``starid.identify``
takes it for every call its native fast path does not answer, and images come here once their
spots are extracted."""

from __future__ import annotations

from typing import Any, Optional

import numpy.typing as npt

from . import _starid
from ._args import Identification, _camera, _config, _flag, _fov_range, _hint, _image_size, _magnitudes, _positive, _xy
from ._catalog import CatalogLike, resolve_catalog_for
from ._errors import InvalidInputError
from ._unknown_field import identify_unknown_field

__all__ = ["identify_centroids"]


def identify_centroids(
    xy: npt.ArrayLike,
    catalog: CatalogLike,
    fov_deg: Optional[float],
    image_size: Optional[tuple[float, float]],
    magnitudes: Optional[npt.ArrayLike],
    *,
    camera: Optional[Any] = None,
    fov_range_deg: Optional[tuple[float, float]] = None,
    attitude_hint: Optional[Any] = None,
    hint_uncertainty_deg: float = 1.0,
    hint_fallback: bool = True,
    config: Optional[Any] = None,
    **settings: Any,
) -> Identification:
    """The identification of centroids ``xy`` (pixels, starid's origin) as
    :func:`starid.identify` describes it; ``settings`` are :class:`starid.IdentifyConfig`
    keywords (``mag_offset`` among them)."""
    cam = _camera(camera, fov_deg, image_size)
    a = _xy(xy)
    m = _magnitudes(magnitudes, a.shape[0])
    cfg = _config(config, settings)
    if cam is None:
        size = _image_size(image_size)
        rng = None if fov_range_deg is None else _fov_range(fov_range_deg)
        res = identify_unknown_field(catalog, [a], [m], size, rng, cfg, None)[0]
        if res.status == "invalid_input":  # one frame's malformed input is an error, not a status
            raise InvalidInputError(str(res.message).removeprefix("frame 0: "))
        return res  # type: ignore[no-any-return]  # an Identification
    cat = resolve_catalog_for(catalog, cam, m, cfg.mag_offset)
    if fov_range_deg is not None:
        raise InvalidInputError("give fov_deg (a known field of view) or fov_range_deg (an unknown one), not both")
    if attitude_hint is not None:
        q, mirrored = _hint(attitude_hint)
        return _starid.identify_hinted(
            cat._native, a, m, cam, cfg, q, _positive("hint_uncertainty_deg", hint_uncertainty_deg), mirrored, _flag("hint_fallback", hint_fallback)
        )
    return _starid.identify(cat._native, a, m, cam, cfg)
