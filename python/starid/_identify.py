"""Identification of one frame and the frame simulator: the Python surface (batches: ``_batch``)."""

from __future__ import annotations

import math
import numbers
import os
import secrets
from dataclasses import dataclass, field
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._errors import InvalidInputError
from ._catalog import Catalog, resolve_catalog, resolve_catalog_for
from ._centroids import Centroids
from ._unknown_field import DEFAULT_FOV_RANGE_DEG, identify_unknown_field

__all__ = ["DEFAULT_FOV_RANGE_DEG", "Frame", "Identification", "identify", "simulate"]

CatalogLike = Union[Catalog, str, "os.PathLike[str]", None]


#: The identification methods, name -> one-line description (``method=`` of :func:`identify`).
METHODS: dict[str, str] = dict(_starid.methods())

#: The scene families of :func:`simulate_scene`.
SCENE_FAMILIES = ("K1", "K2", "K3")

#: The result of :func:`identify`: a native, immutable class (see its docstring for the fields).
Identification = _starid.Identification


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


def _whole(name: str, value: Any, limit: int = 2**63 - 1) -> int:
    """A non-negative whole number (an int, or a float with an integral value) up to ``limit``,
    or an InvalidInputError naming it."""
    try:
        v = int(value)
    except (TypeError, ValueError, OverflowError) as e:
        raise InvalidInputError(f"{name} must be a whole number, got {value!r}") from e
    if isinstance(value, bool) or v != value or not 0 <= v <= limit:
        raise InvalidInputError(f"{name} must be a whole number in [0, {limit}], got {value!r}")
    return v


_SIZES: dict[Any, tuple[float, float]] = {}
_CONFIGS: dict[tuple[Any, ...], Any] = {}


def _image_size(image_size: Any) -> tuple[float, float]:
    # The same few sizes come call after call: checked once (a hashable size only).
    try:
        return _SIZES[image_size]
    except (KeyError, TypeError):
        pass
    w, h = _check_image_size(image_size)
    if isinstance(image_size, tuple) and len(_SIZES) < 256:
        _SIZES[image_size] = (w, h)
    return w, h


def _number(name: str, value: Any) -> float:
    """``value`` as a float: a real number (a numpy scalar included), never a bool or a string
    (``float(True)`` is 1, ``float("12")`` 12: neither is what a caller meant)."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(value, (numbers.Real, np.ndarray)):
        raise InvalidInputError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"{name} must be a number, got {value!r}") from e


def _flag(name: str, value: Any) -> bool:
    """``value`` as a bool: True or False (numpy's included), never a string such as ``"no"``
    or a number."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InvalidInputError(f"{name} must be True or False, got {type(value).__name__} {value!r}")


def _check_image_size(image_size: Any) -> tuple[float, float]:
    if image_size is None:
        raise InvalidInputError("image_size=(width_px, height_px) is required")
    try:
        w, h = (_number("image_size", v) for v in image_size)
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"image_size must be a pair (width_px, height_px), got {image_size!r}") from None
    if not (math.isfinite(w) and math.isfinite(h) and w >= 1 and h >= 1):
        raise InvalidInputError(f"image_size must be positive and finite, got {image_size!r}")
    return w, h


def _fov_range(fov_range_deg: Any) -> tuple[float, float]:
    try:
        lo, hi = (_number("fov_range_deg", v) for v in fov_range_deg)
    except (TypeError, ValueError):
        raise InvalidInputError(f"fov_range_deg must be a pair (lo, hi) in degrees, got {fov_range_deg!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi < 179.0):
        raise InvalidInputError(f"fov_range_deg must satisfy 0 < lo <= hi < 179 degrees, got {fov_range_deg!r}")
    return lo, hi


def _fov(fov_deg: Any) -> float:
    if fov_deg is None:
        raise InvalidInputError("fov_deg (the full field of view across the image width, degrees) is required")
    fov = _number("fov_deg", fov_deg)
    if not (math.isfinite(fov) and 0.0 < fov < 179.0):
        raise InvalidInputError(f"fov_deg must be in (0, 179) degrees, got {fov_deg!r}")
    return fov


def _xy(xy: Any, name: str = "xy") -> npt.NDArray[np.float64]:
    # A float64 (N, 2) array as it is (the common case: nothing to convert).
    if type(xy) is np.ndarray and xy.dtype is _F64 and xy.ndim == 2 and xy.shape[1] == 2:
        return xy
    try:
        a = np.ascontiguousarray(xy, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"{name} must be an (N, 2) array of pixel centroids: {e}") from e
    if a.size == 0 and a.ndim <= 2:
        return np.empty((0, 2), dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 2:
        raise InvalidInputError(f"{name} must have shape (N, 2) holding (x, y) pixel centroids, got shape {a.shape}")
    return a


def _magnitudes(magnitudes: Any, n: int) -> Optional[npt.NDArray[np.float64]]:
    if magnitudes is None:
        return None
    if type(magnitudes) is np.ndarray and magnitudes.dtype is _F64 and magnitudes.ndim == 1:
        m = magnitudes
    else:
        try:
            m = np.ascontiguousarray(magnitudes, dtype=np.float64).ravel()
        except (TypeError, ValueError) as e:
            raise InvalidInputError(f"magnitudes must be numeric: {e}") from e
    if m.shape[0] != n:
        raise InvalidInputError(f"magnitudes has {m.shape[0]} values for {n} centroids")
    return m


#: The identification settings (keywords of :func:`identify`), written once, in the core.
IdentifyConfig = _starid.IdentifyConfig
Camera = _starid.Camera

_DEFAULT_CONFIG = IdentifyConfig()
_UNKNOWN_ZERO_POINT_CONFIG = IdentifyConfig(mag_offset=None)
# identify()'s mag_offset when not given (None is a value: the zero point is unknown).
class _Default:
    """``mag_offset``'s default: 0.0, the catalogue's system, unless ``config`` says otherwise
    (so that a config's own ``mag_offset`` is not overridden by a keyword nobody gave)."""

    def __repr__(self) -> str:
        return repr(_DEFAULT_CONFIG.mag_offset)  # the core's default, written once there


_UNSET: Any = _Default()
_F64 = np.dtype(np.float64)
_CAMERAS: dict[Any, Any] = {}


def _is_image(x: Any) -> bool:
    """Whether ``identify``'s first argument is an image: a path, a colour array (H, W, 3|4),
    or a 2-D array at least 16 pixels on each side (a centroid list has 2 columns; an (N, 3)
    one is a mistake to report, not a picture). Arrays are looked at first: the common case
    costs a shape test."""
    if isinstance(x, np.ndarray):
        s = x.shape
        return (len(s) == 3 and s[2] in (3, 4) and min(s[0], s[1]) >= 16) or (len(s) == 2 and min(s) >= 16)
    return isinstance(x, (str, os.PathLike))


def _config(config: Any, settings: dict[str, Any]) -> Any:
    """The native settings: ``config`` (an IdentifyConfig or None) with ``settings`` applied,
    each distinct set checked once by the core and cached."""
    if config is not None and not isinstance(config, IdentifyConfig):
        raise InvalidInputError(f"config must be a starid.IdentifyConfig, got {type(config).__name__}")
    if not settings:
        return _DEFAULT_CONFIG if config is None else config
    if config is not None:
        return config.replace(**settings)
    try:
        key = tuple(settings.items())
        return _CONFIGS[key]
    except (KeyError, TypeError):
        pass
    try:
        cfg = IdentifyConfig(**settings)
    except TypeError as e:
        raise TypeError(f"{_culprit(settings)}{e}; the settings are {', '.join(IdentifyConfig.names())}") from None
    if len(_CONFIGS) < 256:
        try:
            _CONFIGS[key] = cfg
        except TypeError:
            pass
    return cfg


def _culprit(settings: dict[str, Any]) -> str:
    """``"name: "`` of the first known setting whose value alone the settings refuse as of the
    wrong type (the native message does not name it), else ``""``."""
    names = set(IdentifyConfig.names())
    for name, value in settings.items():
        if name in names:
            try:
                IdentifyConfig(**{name: value})
            except TypeError:
                return f"{name}: "
            except Exception:
                pass
    return ""


def _camera(camera: Any, fov_deg: Any, image_size: Any) -> Any:
    """The camera of a call: ``camera``, or one made from ``fov_deg`` and ``image_size``
    (cached per distinct pair); None when the field of view is unknown."""
    if camera is not None:
        if not isinstance(camera, Camera):
            raise InvalidInputError(f"camera must be a starid.Camera, got {type(camera).__name__}")
        if fov_deg is not None or image_size is not None:
            raise InvalidInputError("give camera=, or fov_deg and image_size, not both")
        return camera
    if fov_deg is None:
        return None
    if isinstance(fov_deg, (bool, np.bool_)):  # True == 1 would find the camera of 1° below
        _fov(fov_deg)
    key = (fov_deg, image_size)
    try:
        return _CAMERAS[key]
    except (KeyError, TypeError):
        pass
    cam = Camera(_image_size(image_size), _fov(fov_deg))
    if len(_CAMERAS) < 256:
        try:
            _CAMERAS[key] = cam
        except TypeError:
            pass
    return cam


def identify(
    xy: npt.ArrayLike,
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    image_size: Optional[tuple[float, float]] = None,
    *,
    camera: Optional[Any] = None,
    fov_range_deg: Optional[tuple[float, float]] = None,
    magnitudes: Optional[npt.ArrayLike] = None,
    attitude_hint: Optional[Any] = None,
    hint_uncertainty_deg: float = 1.0,
    hint_fallback: bool = True,
    config: Optional[Any] = None,
    mag_offset: Optional[float] = _UNSET,
    pixel_origin: str = "corner",
    **settings: Any,
) -> Identification:
    """Identify the stars of one frame (lost in space: no prior attitude).

    Parameters
    ----------
    xy : array_like, shape (N, 2), Centroids or image
        Pixel centroids: x to the right, y down, origin at the sensor's top-left corner. The
        :class:`~starid.images.Centroids` that :func:`~starid.extract_centroids` returns bring
        their instrument magnitudes (zero point unknown) and the image's size; an image (an
        array or a file) is extracted first.
    catalog : Catalog, path or None
        The star catalogue; None chooses a bundled Hipparcos catalogue as deep as the field
        (and the spots' magnitudes) need: see :func:`~starid.catalog_for`.
    fov_deg : float, optional
        Full field of view across the image width, degrees: an estimate, good to
        ``fov_tolerance`` (10 % by default; the field found is ``fov_deg`` on the result). When
        omitted, the field of view is unknown: it is searched in ``fov_range_deg`` and estimated
        (``focal_px``, ``fov_deg`` and ``focal_sigma_px`` on the result).
    image_size : (width_px, height_px)
        Sensor size; the optical axis meets it at ``(width/2, height/2)``.
    camera : Camera, optional
        The camera as one object (size, focal length, principal point, Brown–Conrady
        distortion; ``starid.calibrate`` fits one), instead of ``fov_deg`` and ``image_size``.
    fov_range_deg : (lo, hi), optional
        Range of the unknown field of view; only without ``fov_deg``. Without either, the
        brightest spots are searched in 4 to 60 degrees, band by band, each band with a
        catalogue deep enough for it, then every spot in :data:`DEFAULT_FOV_RANGE_DEG` (8 to
        25 degrees); a range given narrows the bands (see ``starid._unknown_field``).
    magnitudes : array_like, shape (N,), optional
        Instrument magnitude of each centroid (smaller is brighter; any zero point). The search
        starts from the brightest stars (among catalogue stars that are locally bright first,
        which is fast), and a centroid more than 1 mag (or 5 robust sigma) brighter than its
        catalogue star, after the frame's fitted offset, is left unidentified: usually a false
        star on the spot of a star too faint to be seen.
    attitude_hint : Identification, quaternion or (ra_deg, dec_deg, roll_deg), optional
        The attitude roughly known (tracking): a previous result (its attitude and
        handedness), a quaternion ``[w, x, y, z]`` ICRS -> camera as results report it, or
        RA/Dec/roll in degrees. Spots are matched to the stars the hint predicts within
        ``hint_uncertainty_deg``; the false-match bound counts that region instead of the whole
        sky, so a tight hint can name a frame of 2 or 3 stars. The result's ``hinted`` says
        whether the hint found it. Needs a known field of view.
    hint_uncertainty_deg : float
        How far the true attitude may be from the hint (rotation angle, degrees, at most 20).
    hint_fallback : bool
        When nothing within the hint verifies: identify lost in space (True, default) or
        report ``no_match`` (False). A wrong hint never yields a wrong identification.
    config : IdentifyConfig, optional
        Settings as one object; keywords below override them.
    **settings
        The settings of :class:`IdentifyConfig` (defaults from the core):

    centroid_sigma_px : float, optional
        Centroid noise (1 sigma per axis). By default the search adapts: tight tolerances
        first (0.2 px), then 0.7 px, then 2.5 px.
    max_false_match_prob : float
        A solution is reported only if its bound on the probability of a false match is at
        most this.
    min_matches : int
        Fewest identified stars in a reported solution (at least 3, the default). Three stars
        alone are named only where their triangle's sides and magnitudes pass the false-match
        bound by themselves; 4 turns that off.
    max_search_stars : int
        Centroids (brightest first) used to form search triangles; all are verified.
    max_hypotheses : int
        Give up after testing this many catalogue triangles.
    max_pairs_visited : int
        Give up after this much search work (catalogue pairs read and nearest-star look-ups):
        the bound on the time of a frame that cannot be identified.
    allow_mirrored : bool
        Also search mirrored frames; the result says which handedness was found.
    timeout_s : float, optional
        Give up after this long (status ``"timeout"``). By default the result depends only on
        the input; hopeless frames end within a fixed search budget.
    method : str
        How hypotheses are made (every method's pass the same verification): ``"auto"``
        (default: Pyramid over the brightest stars, then, with magnitudes and a known zero
        point, a magnitude-gated Pyramid over every centroid, which finds a few real stars among
        many false ones), ``"pyramid"`` or ``"voting"`` (geometric voting). See :data:`METHODS`.
    mag_offset : float or None
        Instrument minus catalogue magnitude (default 0: magnitudes in the catalogue's system).
        The magnitude-gated search runs only when most centroids' magnitudes, less this offset,
        fall within ``mag_tolerance`` of some catalogue star's, so an arbitrary instrument zero
        point is searched without the gate by itself. ``None`` says the zero point is unknown:
        only the brightness order is used, and frames where false stars outnumber real ones
        are rarely identified.
    pixel_origin : {"corner", "center"}
        Where ``xy``'s pixel coordinates start. ``"corner"`` (starid's, the default): the first
        pixel spans 0 to 1, its centre at 0.5. ``"center"``: the first pixel's centre at 0, as
        sep, photutils and astropy give centroids; half a pixel is added to x and y, and the
        result's ``xy`` and table are in starid's convention.
    mag_tolerance : float
        Largest difference (after ``mag_offset``) between a centroid's magnitude and its
        catalogue star's in the magnitude-gated search (default 0.5 mag).
    brightness_order : bool
        Without ``magnitudes``, whether ``xy`` lists the spots brightest first, as star
        extractors do (default True): the first few are then tried among the locally bright
        catalogue stars first, which is fast. Pass False for centroids in no particular order
        (such as :func:`simulate`'s, which are shuffled); either way the answer is verified.
    focal_check : bool
        With ``fov_deg`` given (default True): when a solution's residuals grow with their
        distance from the image centre, the field of view was given a little off (a lens's
        nominal focal length, say); the frame is searched again with the focal length they
        imply, reported as ``focal_px`` and ``fov_deg`` with ``focal_sigma_px``. Residuals that
        grow with the cube of the distance say the same of the lens's radial distortion: the
        one found is reported as ``k1`` (and written to the WCS). False holds the given camera
        fixed.
    fov_tolerance : float
        How far off ``fov_deg`` may be, relative (default 0.1: ±10 %). Where the given field
        finds no solution, or one its residuals or unmatched stars put in doubt, the frame is
        searched with the focal length unknown within the tolerance, and the field found
        reported. 0 (or ``focal_check=False``) holds the field as given: for cameras known
        exactly, whose frames then cost no search beyond it. A calibrated camera (principal
        point off the centre, distortion) is held as given.
    learn_zero_point : bool
        :func:`identify_many` only (default True): with ``mag_offset=None`` (or one the
        magnitudes do not fit), the frames identified from the brightness order alone measure
        the magnitudes' zero point; when at least 3 agree (two thirds within 0.5 mag), the
        frames nothing identified are searched again, magnitude-gated, with it (tolerance 2.5
        times the frames' magnitude scatter, 0.5 to 1.5 mag) and report it as
        ``learned_mag_offset``. This is what finds the few real stars among many false spots
        when the magnitudes come from an instrument (an image's always do). False: every frame
        alone.

    Returns
    -------
    Identification
        ``ok`` False (and every id -1) when no solution verifies; never a guess.

    A frame of 0 to 3 centroids is an observation, not an error: its status is
    ``"too_few_stars"``. Centroids up to one sensor size outside the sensor are accepted (a
    star cut by the edge can centroid just outside it).

    Raises
    ------
    ValueError
        For NaN/infinite or duplicate centroids, centroids off the
        sensor, a field of view outside (0, 179) degrees, or inconsistent arguments.

    Examples
    --------
    >>> import starid
    >>> frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=3, noise_px=0.2)
    >>> res = starid.identify(frame.xy, fov_deg=12.0, image_size=(512, 512))
    >>> res.ok, bool((res.ids == frame.true_ids).all())
    (True, True)

    With the field of view unknown (searched over 4 to 60 degrees, band by band):

    >>> frame = starid.simulate(fov_deg=17.3, image_size=(1024, 1024), seed=8, noise_px=0.2)
    >>> res = starid.identify(frame.xy, image_size=(1024, 1024))
    >>> res.ok, round(res.fov_deg, 2)
    (True, 17.3)
    """
    if isinstance(xy, Centroids):
        # Spots extracted by starid: their positions, instrument magnitudes and sensor size.
        if magnitudes is not None:
            raise InvalidInputError("Centroids carry their magnitudes: do not pass magnitudes=")
        if image_size is None and camera is None:
            image_size = xy.image_size
        if mag_offset is _UNSET and config is None:
            mag_offset = None  # instrument magnitudes: their zero point is unknown
        magnitudes = xy.magnitudes if np.isfinite(xy.magnitudes).all() else None
        xy = xy.xy
    if pixel_origin != "corner":
        xy = _from_pixel_origin(xy, pixel_origin)
    # The common call (float64 arrays, a known camera) in one native step; any other form comes
    # back NotImplemented and takes the path below, which converts, checks or reads it.
    # The camera, catalogue and settings of the most common call are looked up inline (each
    # helper call costs about as much as the lookup): see _camera, resolve_catalog_for, _config.
    if fov_range_deg is None and (camera is not None or (fov_deg is not None and image_size is not None)):
        if camera is None:
            try:
                cam = _CAMERAS[(fov_deg, image_size)]
            except (KeyError, TypeError):
                cam = _camera(None, fov_deg, image_size)
        else:
            cam = _camera(camera, fov_deg, image_size)
        # mag_offset is a named keyword so that its common values need no settings dict.
        if config is None and not settings:
            if mag_offset is _UNSET:
                cfg = _DEFAULT_CONFIG
            elif mag_offset is None:
                cfg = _UNKNOWN_ZERO_POINT_CONFIG
            else:
                cfg = _config(None, {"mag_offset": mag_offset})
        elif config is not None or mag_offset is not _UNSET:
            cfg = _config(config, settings if mag_offset is _UNSET else {**settings, "mag_offset": mag_offset})
        else:
            try:
                cached = _CONFIGS.get(tuple(settings.items()))
            except TypeError:  # a setting's value cannot be a key
                cached = None
            # Built outside the handler, so that a refused setting's error chains to nothing.
            cfg = _config(None, settings) if cached is None else cached
        cat = catalog if type(catalog) is Catalog else resolve_catalog_for(catalog, cam, magnitudes, cfg.mag_offset)
        res = _starid.identify_frame(
            cat._native, xy, magnitudes, cam, cfg, attitude_hint, hint_uncertainty_deg, hint_fallback
        )
        if res is not NotImplemented:
            return res  # type: ignore[return-value]  # an Identification: the native call's other answer
    if mag_offset is not _UNSET:
        settings["mag_offset"] = mag_offset
    if _is_image(xy):
        from .images import identify_image

        if magnitudes is not None:
            raise InvalidInputError("an image's magnitudes come from its spots: do not pass magnitudes=")
        return identify_image(
            xy, catalog, fov_deg, image_size=image_size, camera=camera, fov_range_deg=fov_range_deg,
            attitude_hint=attitude_hint, hint_uncertainty_deg=hint_uncertainty_deg, hint_fallback=hint_fallback,
            config=config, **settings,
        ).identification
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


#: What ``pixel_origin`` may say: starid's convention, and that of sep, photutils and astropy.
PIXEL_ORIGINS = ("corner", "center")


def _from_pixel_origin(xy: Any, pixel_origin: Any) -> Any:
    """Centroids in starid's pixels (the first pixel spans 0 to 1, its centre at 0.5) from
    ``pixel_origin="center"`` ones (sep, photutils and astropy put the first pixel's centre at
    0): exactly half a pixel added to x and y."""
    if pixel_origin not in PIXEL_ORIGINS:
        raise InvalidInputError(f"pixel_origin must be one of {PIXEL_ORIGINS}, got {pixel_origin!r}")
    if pixel_origin == "corner":
        return xy
    if _is_image(xy):
        raise InvalidInputError("pixel_origin is for centroids given as numbers; an image's spots are starid's own")
    return _xy(xy) + 0.5


def _positive(name: str, value: Any) -> float:
    v = _number(name, value)
    if not (math.isfinite(v) and v > 0):
        raise InvalidInputError(f"{name} must be positive and finite, got {value!r}")
    return v


def _hint(hint: Any) -> tuple[list[float], Optional[bool]]:
    """``[w, x, y, z]`` and the handedness (None: unknown) of an attitude hint."""
    if isinstance(hint, Identification):
        q = hint.quaternion
        if not hint.ok or q is None:
            raise InvalidInputError("attitude_hint is an identification without a solution")
        return q.tolist(), bool(hint.mirrored)
    # The common forms without numpy's per-call costs: a float array or a short list.
    try:
        if isinstance(hint, np.ndarray) and hint.ndim == 1:
            vals = [float(x) for x in hint.tolist()]
        else:
            vals = [float(x) for x in np.asarray(hint, dtype=np.float64).ravel().tolist()]
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"attitude_hint must be a quaternion [w, x, y, z] or (ra_deg, dec_deg, roll_deg): {e}") from e
    if not all(math.isfinite(x) for x in vals):
        raise InvalidInputError(f"attitude_hint must be finite, got {hint!r}")
    v = vals
    if len(v) == 4:
        return v, None
    if len(v) == 3:
        ra, dec, roll = (math.radians(float(x)) for x in v)
        if abs(dec) > math.pi / 2:
            raise InvalidInputError(f"attitude_hint declination must be in [-90, 90] degrees, got {v[1]}")
        return _radec_roll_quaternion(ra, dec, roll), None
    raise InvalidInputError(f"attitude_hint must be a quaternion [w, x, y, z] or (ra_deg, dec_deg, roll_deg), got {len(v)} values")


def _radec_roll_quaternion(ra: float, dec: float, roll: float) -> list[float]:
    """``[w, x, y, z]`` of the attitude at boresight (ra, dec) and roll (radians), by the core's
    convention (see ``Identification.roll_deg``)."""
    return [float(x) for x in _starid.quaternion_from_radec_roll(ra, dec, roll)]


def _invalid(message: str, n: int) -> Identification:
    """The result of a malformed frame of a batch: status ``invalid_input``, every id -1."""
    nan = float("nan")
    floats = [nan, nan, 0.0, nan, nan, nan, nan, 0.0, nan, nan, nan, nan, nan, nan, 0.0, 0.0, 0.0, 0.0, nan, nan]
    state: tuple[Any, ...] = ("invalid_input", [-1] * n, [nan] * n, None, False, 1.0, 0, floats, 0, "auto", message,
                              (False, False, None, ([], None, []), "none"))
    return Identification._from_state(state)


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
