"""The frame simulator: centroids a star tracker would see, and scenes of the hostile-field
families, with their truth."""

from __future__ import annotations

import secrets
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from . import _starid
from ._args import _camera, _fov, _image_size
from ._catalog import Catalog, CatalogLike, resolve_catalog, resolve_catalog_for
from ._errors import InvalidInputError

__all__ = ["SCENE_FAMILIES", "Frame", "simulate", "simulate_scene"]

#: The scene families of :func:`simulate_scene`.
SCENE_FAMILIES = ("K1", "K2", "K3")

@dataclass(frozen=True)
class Frame:
    """A simulated frame and its truth (see :func:`simulate`)."""

    xy: npt.NDArray[np.float64]
    magnitudes: npt.NDArray[np.float64]
    true_ids: npt.NDArray[np.int64]
    ra_deg: float
    dec_deg: float
    roll_deg: float
    rotation_matrix: npt.NDArray[np.float64]
    quaternion: npt.NDArray[np.float64]
    mirrored: bool
    fov_deg: float
    image_size: tuple[float, float]
    seed: int = field(default=0)

    @property
    def n_real(self) -> int:
        """Number of centroids that are catalogue stars."""
        return int(np.count_nonzero(self.true_ids >= 0))


def _frame(d: dict[str, Any], fov_deg: float, image_size: tuple[float, float], seed: int, cls: Any = None, **extra: Any) -> Any:
    """A :class:`Frame` (or ``cls``) from the native simulator's dict and the camera."""
    return (cls or Frame)(
        xy=d["xy"],
        magnitudes=d["magnitudes"],
        true_ids=d["true_ids"],
        ra_deg=d["ra_deg"],
        dec_deg=d["dec_deg"],
        roll_deg=d["roll_deg"],
        rotation_matrix=d["rotation_matrix"],
        quaternion=d["quaternion"],
        mirrored=d["mirrored"],
        fov_deg=float(fov_deg),
        image_size=(float(image_size[0]), float(image_size[1])),
        seed=int(seed),
        **extra,
    )


def simulate(
    catalog: CatalogLike = None,
    fov_deg: float = 12.0,
    image_size: tuple[float, float] = (512, 512),
    *,
    attitude_deg: Optional[tuple[float, float, float]] = None,
    seed: Optional[int] = None,
    mag_limit: Optional[float] = None,
    noise_px: float = 0.0,
    mag_noise: float = 0.0,
    false_stars: int = 0,
    drop_fraction: float = 0.0,
    mirrored: bool = False,
    radial_k1: float = 0.0,
    camera: Optional[Any] = None,
) -> Frame:
    """Simulate the centroids a star tracker would see.

    Parameters
    ----------
    catalog : Catalog, path or None
        Stars to draw from (None: the bundled catalogue).
    fov_deg, image_size
        Field of view across the width (degrees) and sensor size (pixels).
    attitude_deg : (ra, dec, roll) in degrees, optional
        The pointing; by default a uniformly random attitude.
    seed : int, optional
        Seed of the random generator (random when None); the same seed gives the same frame.
    mag_limit : float, optional
        Only stars with ``mag <= mag_limit`` appear.
    noise_px : float
        Gaussian centroid noise, 1 sigma per axis.
    mag_noise : float
        Gaussian noise on the reported magnitudes (shuffles their order).
    false_stars : int
        False stars spread uniformly over the sensor.
    drop_fraction : float
        Probability that a real star is missing.
    mirrored : bool
        Reverse the x axis (``x -> W - x``), as an odd number of reflections would.
    radial_k1 : float
        Radial distortion: a star at normalised camera coordinates ``(u, v)`` is imaged at
        ``centre + f * (u, v) * (1 + radial_k1 * (u**2 + v**2))`` (negative: barrel).
    camera : Camera, optional
        The camera whole (its principal point and full distortion, a calibrated one), instead of
        ``fov_deg``, ``image_size`` and ``radial_k1``.

    Returns
    -------
    Frame
        ``xy``, ``magnitudes``, ``true_ids`` (-1 for false stars) and the true attitude.

    Examples
    --------
    >>> import starid
    >>> f = starid.simulate(fov_deg=12.0, image_size=(512, 512), attitude_deg=(83.8, -5.4, 0.0), seed=1)
    >>> f.n_real > 10
    True
    """
    if camera is not None:
        cam = _camera(camera, None, None)
        if radial_k1 != 0.0:
            raise InvalidInputError("give the distortion in the camera, not radial_k1 beside it")
        (w, h), fov = cam.image_size, cam.fov_deg
    else:
        w, h = _image_size(image_size)
        fov = _fov(fov_deg)
        cam = _camera(None, fov, (w, h))
    cat = resolve_catalog_for(catalog, cam)
    if seed is None:
        seed = secrets.randbits(63)
    seed = int(seed)
    if not 0 <= seed < 2**64:
        raise InvalidInputError(f"seed must be in [0, 2**64), got {seed}")
    att = None if attitude_deg is None else tuple(float(v) for v in attitude_deg)
    if att is not None and len(att) != 3:
        raise InvalidInputError("attitude_deg must be (ra_deg, dec_deg, roll_deg)")
    if int(false_stars) < 0:
        raise InvalidInputError(f"false_stars must be >= 0, got {false_stars}")
    d = _starid.simulate(
        cat._native,
        fov,
        w,
        h,
        seed,
        att,
        None if mag_limit is None else float(mag_limit),
        float(noise_px),
        float(mag_noise),
        int(false_stars),
        float(drop_fraction),
        bool(mirrored),
        float(radial_k1),
        camera,
    )
    frame: Frame = _frame(d, fov, (w, h), seed)
    return frame


def simulate_scene(family: str, catalog: CatalogLike = None, *, seed: Optional[int] = None) -> Frame:
    """Simulate a scene of a hostile-field family, with its camera.

    ``"K1"`` (Kelvins "Star Trackers: First Contact" style: 1920x1440 px, 10 x 7.5 degrees,
    stars to magnitude 6.2 after photometric noise, 0-80 false spots with catalogue-like
    magnitudes), ``"K2"`` (narrow: 1392x1080 px, 6 degrees, stars to 7.75, 0-10 false spots;
    with catalog=None the deep bundled catalogue, to Hp 8) or ``"K3"`` (deep: 15.78 arcsec/px, stars to 11 among
    stars the catalogue lacks; a catalogue to 11). Scenes of odd seed are mirrored; spots come in
    random order with magnitudes in the catalogue's system.

    Examples
    --------
    >>> import starid
    >>> f = starid.simulate_scene("K1", seed=4)
    >>> f.image_size, round(f.fov_deg, 1)
    ((1920.0, 1440.0), 10.0)
    """
    if not isinstance(family, str) or family.upper() not in SCENE_FAMILIES:
        raise InvalidInputError(f"family must be one of {', '.join(SCENE_FAMILIES)}, got {family!r}")
    # K2's narrow field needs stars to magnitude 8: the deep bundled catalogue by default.
    cat = Catalog.deep() if catalog is None and family.upper() == "K2" else resolve_catalog(catalog)
    if seed is None:
        seed = secrets.randbits(63)
    seed = int(seed)
    if not 0 <= seed < 2**64:
        raise InvalidInputError(f"seed must be in [0, 2**64), got {seed}")
    d = _starid.simulate_scene(cat._native, family.upper(), seed)
    frame: Frame = _frame(d, d["fov_deg"], (d["width_px"], d["height_px"]), seed)
    return frame
