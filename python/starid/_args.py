"""The arguments of an identification call, checked and converted once: sizes, fields of view,
centroids, magnitudes, attitude hints, cameras and settings (a leaf: no other starid module but
the core's bindings and errors)."""

from __future__ import annotations

import math
import numbers
import os
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from . import _starid
from ._errors import InvalidInputError

#: The identification methods, name -> one-line description (``method=`` of :func:`identify`).
METHODS: dict[str, str] = dict(_starid.methods())

#: The result of :func:`identify`: a native, immutable class (see its docstring for the fields).
Identification = _starid.Identification


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
    return Identification._invalid_input(message, n)
