"""Camera calibration from many sky frames: one camera (focal length, principal point,
Brown–Conrady distortion) fitted jointly to every frame's identified stars.

>>> import starid
>>> truth = starid.Camera((1024, 768), 30.0, principal_point=(520.0, 380.0), k1=-0.1)
>>> frames = [starid.simulate(camera=truth, noise_px=0.2, seed=s) for s in range(8)]
>>> nominal = starid.Camera((1024, 768), 30.0)
>>> cal = starid.calibrate([f.xy for f in frames], camera=nominal)
>>> abs(cal.camera.k1 - truth.k1) < 0.01 and cal.rms_px < 0.25
True
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Optional, Sequence

import numpy as np

from . import _starid
from ._batch import identify_many
from ._errors import InvalidInputError
from ._files import checked_input, write_atomically
from ._args import Camera, _camera

__all__ = ["calibrate", "load_camera", "save_camera"]

#: The ``format`` field of a saved camera.
CAMERA_FORMAT = "starid-camera"


def _unit_vectors(ra_deg: np.ndarray, dec_deg: np.ndarray) -> np.ndarray:
    ra, dec = np.radians(ra_deg), np.radians(dec_deg)
    return np.column_stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)])


def _frames_of(results: Sequence[Any]) -> list[tuple[Any, Any, Any, bool]]:
    """The identified frames of ``results`` as the native fit takes them: spots, their stars'
    unit vectors, the rotation and the handedness; frames not identified are left out."""
    frames = []
    for r in results:
        r = getattr(r, "identification", r)  # an ImageIdentification
        if not r.ok:
            continue
        named = np.asarray(r.ids) >= 0
        xy = np.asarray(r.xy, dtype=np.float64)
        if len(xy) != len(named):
            raise InvalidInputError("an identification without its spots cannot calibrate (identify it again with this version)")
        ra, dec, _ = r._star_columns()
        frames.append(
            (
                np.ascontiguousarray(xy[named]),
                np.ascontiguousarray(_unit_vectors(ra[named], dec[named])),
                np.ascontiguousarray(r.rotation_matrix, dtype=np.float64),
                bool(r.mirrored),
            )
        )
    return frames


def _is_result(item: Any) -> bool:
    return isinstance(getattr(item, "identification", item), _starid.Identification)


def _named(results: Sequence[Any]) -> int:
    return sum(int((np.asarray(getattr(r, "identification", r).ids) >= 0).sum()) for r in results)


def calibrate(
    frames: Sequence[Any],
    camera: Optional[Camera] = None,
    *,
    fov_deg: Optional[float] = None,
    image_size: Optional[tuple[float, float]] = None,
    catalog: Any = None,
    focal_length: bool = True,
    principal_point: Optional[bool] = None,
    radial_terms: Optional[int] = None,
    decentering: Optional[bool] = None,
    clip_sigma: float = 3.0,
    max_iterations: int = 100,
    rounds: int = 4,
    **settings: Any,
) -> Any:
    """Fit one camera to many frames of it: one attitude per frame and the intrinsics they
    share, as one least-squares problem (the attitude blocks eliminated through the Schur
    complement, the shared system solved with faer).

    Parameters
    ----------
    frames : sequence
        Identifications (:class:`~starid.Identification`, from :func:`~starid.identify` or
        :func:`~starid.identify_many`; frames not identified are skipped), or frames to identify
        first: centroid arrays ``(N, 2)``, images or image paths, as :func:`~starid.identify_many`
        takes them.
    camera : Camera, optional
        The starting camera (its nominal focal length; the principal point at the centre). Frames
        to identify need it (or ``fov_deg`` and ``image_size``). For identifications it defaults
        to the first one's camera.
    focal_length : bool
        Fit it (True) or hold the starting camera's.
    principal_point : bool, optional
        Fit it, or hold the starting camera's (False); None chooses as ``radial_terms`` does, so
        that a few frames of few stars do not move it on noise.
    radial_terms : int, optional
        Radial terms fitted: 0 to 3 (``k1``, ``k1, k2``, ``k1..k3``). None chooses by the
        Hannan–Quinn criterion, so that terms the field cannot fix (``k3`` of a narrow lens) stay 0.
    decentering : bool, optional
        Fit the decentering terms ``p1, p2``; None chooses as above.
    clip_sigma : float
        Matches whose residual is less likely than a ``clip_sigma``-sigma normal deviation are
        clipped (after a Cauchy-weighted start), and the fit repeated; 0 keeps every match.
    rounds : int
        For frames identified here: identify again with the camera found, and fit again, while
        that names more stars (at most ``rounds`` fits). Frames the starting camera could not
        identify (a strongly distorted lens) are so identified with the calibrated one.
    **settings
        Passed to :func:`~starid.identify_many` for frames identified here (``magnitudes``,
        ``mag_offset``, ...).

    Returns
    -------
    Calibration
        ``camera`` (the fitted :class:`~starid.Camera`), ``sigmas`` and ``covariance`` of the
        fitted ``parameters``, ``rms_before_px`` and ``rms_px`` (per axis, of the kept matches,
        before and after), ``clipped`` matches, per-frame ``quaternions`` and residuals,
        ``identified`` (before, after, frames) for frames identified here; ``save(path)`` keeps
        the camera in a JSON file (:func:`load_camera`).
    """
    items = list(frames)
    if not items:
        raise InvalidInputError("calibrate needs at least one frame")
    if isinstance(frames, (str, bytes, os.PathLike, dict)):
        raise InvalidInputError("frames must be a sequence of frames or identifications")
    options = dict(
        focal_length=bool(focal_length),
        principal_point=None if principal_point is None else bool(principal_point),
        radial_terms=None if radial_terms is None else int(radial_terms),
        decentering=None if decentering is None else bool(decentering),
        clip_sigma=float(clip_sigma),
        max_iterations=int(max_iterations),
    )
    if all(_is_result(i) for i in items):
        if settings:
            raise InvalidInputError(f"identification settings given for frames already identified: {sorted(settings)}")
        start = camera if camera is not None else _result_camera(items)
        return _fit(items, start, options)
    if any(_is_result(i) for i in items):
        raise InvalidInputError("give identifications or frames to identify, not both")
    start = _camera(camera, fov_deg, image_size)
    if start is None:
        raise InvalidInputError("frames to identify need the camera (camera=, or fov_deg and image_size)")
    results = identify_many(items, catalog, camera=start, **settings)
    before = sum(getattr(r, "identification", r).ok for r in results)
    # Fit, identify again with the camera found, and fit again on what that names, while it
    # names more stars: each fit from the most stars the cameras so far could name.
    used, cal = results, _fit(results, start, options)
    after = identify_many(items, catalog, camera=cal.camera, **settings)
    for _ in range(max(0, int(rounds) - 1)):
        if _named(after) <= _named(used):
            break
        used, cal = after, _fit(after, start, options)
        after = identify_many(items, catalog, camera=cal.camera, **settings)
    return cal._with_identified((before, sum(getattr(r, "identification", r).ok for r in after), len(items)))


def _fit(results: Sequence[Any], start: Camera, options: dict[str, Any]) -> Any:
    frames = _frames_of(results)
    if not frames:
        bad = [r.message for r in (getattr(x, "identification", x) for x in results) if r.status == "invalid_input"]
        why = f" ({len(bad)} malformed, the first: {bad[0]})" if bad else ""
        raise InvalidInputError(f"no frame was identified: nothing to calibrate from{why}")
    return _starid.calibrate_camera(frames, start, **options)


def _result_camera(results: Sequence[Any]) -> Camera:
    """The camera of the first identified result (its focal length, principal point, ``k1``)."""
    for r in results:
        r = getattr(r, "identification", r)
        if r.ok and math.isfinite(r.focal_px):
            cx, cy = r.principal_point
            return Camera(r.image_size, focal_length_px=r.focal_px, principal_point=(cx, cy), k1=r.k1)
    raise InvalidInputError("no frame was identified: nothing to calibrate from")


def save_camera(camera: Camera, path: Any, calibration: Any = None) -> None:
    """Write ``camera`` (and a calibration's 1 sigma and summary) to a small JSON file, atomically."""
    if not isinstance(camera, Camera):
        raise InvalidInputError(f"camera must be a starid.Camera, got {type(camera).__name__}")
    d = camera.to_dict()
    doc: dict[str, Any] = {"format": CAMERA_FORMAT, "version": 1, "camera": {**d, "image_size": list(d["image_size"]), "principal_point": list(d["principal_point"])}}
    if calibration is not None:
        doc["calibration"] = calibration.to_dict()
    text = json.dumps(doc, indent=2, allow_nan=True) + "\n"

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    write_atomically(path, write)


def load_camera(path: Any) -> Camera:
    """The camera a file of :func:`save_camera` (or ``Calibration.save``) holds."""
    p = checked_input(path, "camera file", max_bytes=1 << 20)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
        if doc.get("format") != CAMERA_FORMAT:
            raise InvalidInputError(f"{p}: not a starid camera file (format {doc.get('format')!r})")
        c = doc["camera"]
        (w, h), (cx, cy) = c["image_size"], c["principal_point"]
        return Camera(
            (float(w), float(h)),
            focal_length_px=float(c["focal_length_px"]),
            principal_point=(float(cx), float(cy)),
            **{k: float(c.get(k, 0.0)) for k in ("k1", "k2", "k3", "p1", "p2")},
        )
    except InvalidInputError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError, UnicodeDecodeError) as e:
        raise InvalidInputError(f"{p}: not a readable starid camera file ({type(e).__name__}: {e})") from None
