"""Tracking: identify frame after frame from the attitude the last ones predict.

A star tracker spends most of its life tracking: it knows roughly where it pointed a moment
ago. :class:`Tracker` propagates the last attitude at the rate it measures across the recent
solutions, identifies each frame from that prediction (hinted identification, the search
region being the prediction's uncertainty), and falls back to lost in space when the
prediction cannot explain a frame (after a loss of lock, or a manoeuvre). When a lost-in-space
solution's focal check finds the field of view given a little off (see ``focal_check`` in
:func:`starid.identify`), the tracker identifies the frames that follow with the focal length
it found. Likewise, with magnitudes in an instrument's system (``mag_offset=None``, or one they
do not fit), it measures their zero point on its solutions and, once three agree, searches the
frames that follow magnitude-gated with it (``learn_zero_point``; reported as
``learned_mag_offset``). :func:`track` runs a recorded sequence; :func:`simulate_sequence` makes one with its
truth.

>>> import starid
>>> seq = starid.simulate_sequence(frames=5, rate_deg_s=2.0, seed=3)
>>> steps = starid.track([f.xy for f in seq], [f.t_s for f in seq], fov_deg=12.0,
...                      image_size=(512, 512), magnitudes=[f.magnitudes for f in seq])
>>> [s.mode for s in steps]
['lost_in_space', 'tracking', 'tracking', 'tracking', 'tracking']
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional, Sequence, Sized

import numpy as np
import numpy.typing as npt

from . import _starid
from ._catalog import CatalogLike, resolve_catalog, resolve_catalog_for
from ._errors import InvalidInputError
from ._args import Identification, _camera, _config, _invalid, _magnitudes, _whole, _xy
from ._simulate import Frame, _frame

__all__ = ["SequenceFrame", "TrackStep", "Tracker", "simulate_sequence", "track"]


@dataclass(frozen=True)
class TrackStep:
    """One frame of a tracked sequence.

    ``mode`` is ``"tracking"`` (found from the prediction) or ``"lost_in_space"``;
    ``rate_deg_s`` the body rate measured so far (camera axes, deg/s; None before two
    solutions); ``uncertainty_deg`` the prediction's search radius (NaN without lock);
    ``predicted_quaternion`` the attitude the frame was searched around.
    """

    t_s: float
    identification: Identification
    mode: str
    rate_deg_s: Optional[npt.NDArray[np.float64]]
    uncertainty_deg: float
    predicted_quaternion: Optional[npt.NDArray[np.float64]]

    @property
    def ok(self) -> bool:
        """Whether the frame was identified."""
        return bool(self.identification.ok)


#: Default of ``Tracker(confirm_unseen_frames=...)`` (the core's).
CONFIRM_UNSEEN_FRAMES: int = _starid.CONFIRM_UNSEEN_FRAMES


def _unseen_frames(value: Optional[int]) -> Optional[int]:
    """``confirm_unseen_frames`` checked: None, or a whole number (the core refuses 0)."""
    return None if value is None else _whole("confirm_unseen_frames", value, 2**32 - 1)


class Tracker:
    """Identify a sequence of frames of one camera, each from the last ones' attitude.

    Parameters
    ----------
    catalog, fov_deg, image_size, camera
        As :func:`starid.identify`.
    max_rate_deg_s : float
        The fastest the camera may turn: bounds the search before a rate is measured.
    min_uncertainty_deg : float
        Smallest search radius around the prediction.
    fallback : bool
        Identify lost in space when the prediction explains nothing (default True).
    confirm_new_stars : bool
        Name a star that the last frame had well inside the sensor but did not name only from
        its second frame in a row (default False). A false spot on a star too faint to be seen
        seldom returns. On 2 450 simulated frames with 0-40 false spots it leaves 2 wrong ids,
        as the default does, and names 0.46 % fewer of the real stars (with neither rule: 9).
        When on, it replaces ``confirm_unseen_frames``.
    confirm_unseen_frames : int or None
        A star that the last this many solutions in a row had well inside the sensor without
        naming it (too faint for this camera) is named only once two frames in a row match it
        (default 10; None turns it off): a false spot that lands on such a star by chance does
        not land on it again in the next frame. A star that no solution named since it came
        well inside is held so after 3 of them (or this many, if fewer): at 5 deg/s a star
        crosses a 12 deg field in 24 frames. Stars that entered the field lately, or that the
        last of those solutions named, are named at once. A star of a magnitude the camera
        rarely detects (under 20 % of such stars matched, as the tracker counts them) is held
        the same way unless the last solution named it. On three sets of simulated sequences
        (29 850 frames, 0-40 false spots, 0.1-5 deg/s) wrong ids fell from 66 without the
        rule to 14, for 78 fewer of 464 470 real stars named; with the magnitude rule and
        the tracker's two other rules (a star just off the sensor, a spot whose brightness
        fits a neighbour better) to 4, for 278 more. A third rule is always on: two named
        spots whose stars, swapped, fit about as well once the centroid noise is measured
        along the image motion and across it (a smear) are not named.
    config, **settings
        Identification settings, as :func:`starid.identify`.

    Examples
    --------
    >>> import starid
    >>> seq = starid.simulate_sequence(frames=3, rate_deg_s=1.0, seed=1)
    >>> tracker = starid.Tracker(fov_deg=12.0, image_size=(512, 512))
    >>> [tracker.update(f.xy, f.t_s, magnitudes=f.magnitudes).mode for f in seq]
    ['lost_in_space', 'tracking', 'tracking']
    """

    def __init__(
        self,
        catalog: CatalogLike = None,
        fov_deg: Optional[float] = None,
        image_size: Optional[tuple[float, float]] = None,
        *,
        camera: Optional[Any] = None,
        max_rate_deg_s: float = 5.0,
        min_uncertainty_deg: float = 0.05,
        fallback: bool = True,
        confirm_new_stars: bool = False,
        confirm_unseen_frames: Optional[int] = CONFIRM_UNSEEN_FRAMES,
        config: Optional[Any] = None,
        **settings: Any,
    ) -> None:
        cam = _camera(camera, fov_deg, image_size)
        if cam is None:
            raise InvalidInputError("tracking needs the camera: fov_deg and image_size, or camera=")
        cat = resolve_catalog_for(catalog, cam)
        self._camera = cam
        self._native = _starid.Tracker(
            cat._native,
            cam,
            _config(config, settings),
            float(max_rate_deg_s),
            float(min_uncertainty_deg),
            bool(fallback),
            bool(confirm_new_stars),
            _unseen_frames(confirm_unseen_frames),
        )

    @property
    def camera(self) -> Any:
        """The camera."""
        return self._camera

    @property
    def has_lock(self) -> bool:
        """Whether a solution is held to predict from."""
        return bool(self._native.has_lock)

    def reset(self) -> None:
        """Forget the lock: the next frame is identified lost in space."""
        self._native.reset()

    def update(self, xy: npt.ArrayLike, t_s: float, *, magnitudes: Optional[npt.ArrayLike] = None) -> TrackStep:
        """Identify the frame taken at ``t_s`` (seconds, any origin) and update the lock."""
        a = _xy(xy)
        m = _magnitudes(magnitudes, a.shape[0])
        try:
            t = float(t_s)
        except (TypeError, ValueError) as e:
            raise InvalidInputError(f"t_s must be a number of seconds, got {t_s!r}") from e
        if not math.isfinite(t):
            raise InvalidInputError(f"t_s must be finite, got {t_s!r}")
        d = self._native.update(a, t, m)
        return TrackStep(
            t_s=t,
            identification=d["identification"],
            mode=str(d["mode"]),
            rate_deg_s=d["rate_deg_s"],
            uncertainty_deg=float(d["uncertainty_deg"]),
            predicted_quaternion=d["predicted_quaternion"],
        )


def track(
    frames: Sequence[npt.ArrayLike],
    times: Sequence[float],
    catalog: CatalogLike = None,
    fov_deg: Optional[float] = None,
    image_size: Optional[tuple[float, float]] = None,
    *,
    magnitudes: Optional[Sequence[Optional[npt.ArrayLike]]] = None,
    camera: Optional[Any] = None,
    max_rate_deg_s: float = 5.0,
    min_uncertainty_deg: float = 0.05,
    fallback: bool = True,
    confirm_new_stars: bool = False,
    confirm_unseen_frames: Optional[int] = CONFIRM_UNSEEN_FRAMES,
    config: Optional[Any] = None,
    **settings: Any,
) -> list[TrackStep]:
    """Track a recorded sequence: ``frames[i]`` (centroids) taken at ``times[i]`` seconds.

    A malformed frame does not stop the sequence: its step's identification has status
    ``invalid_input`` and the reason, naming the frame, in ``message``.
    """
    if len(times) != len(frames):
        raise InvalidInputError(f"{len(times)} times for {len(frames)} frames")
    if magnitudes is not None and len(magnitudes) != len(frames):
        raise InvalidInputError(f"magnitudes has {len(magnitudes)} entries for {len(frames)} frames")
    tracker = Tracker(
        catalog,
        fov_deg,
        image_size,
        camera=camera,
        max_rate_deg_s=max_rate_deg_s,
        min_uncertainty_deg=min_uncertainty_deg,
        fallback=fallback,
        confirm_new_stars=confirm_new_stars,
        confirm_unseen_frames=confirm_unseen_frames,
        config=config,
        **settings,
    )
    out: list[TrackStep] = []
    for i, (f, t) in enumerate(zip(frames, times)):
        try:
            out.append(tracker.update(f, t, magnitudes=None if magnitudes is None else magnitudes[i]))
        except ValueError as e:
            n = len(f) if isinstance(f, Sized) else 0
            out.append(TrackStep(float("nan"), _invalid(f"frame {i}: {e}", n), "lost_in_space", None, float("nan"), None))
    return out


@dataclass(frozen=True)
class SequenceFrame(Frame):
    """A simulated frame of a sequence: :class:`starid.Frame` plus its time ``t_s``."""

    t_s: float = 0.0


def simulate_sequence(
    catalog: CatalogLike = None,
    fov_deg: float = 12.0,
    image_size: tuple[float, float] = (512, 512),
    *,
    frames: int = 100,
    rate_deg_s: float = 1.0,
    frame_rate_hz: float = 10.0,
    jitter_deg: float = 0.001,
    exposure_s: float = 0.02,
    blank: Optional[tuple[int, int]] = None,
    mag_limit: Optional[float] = 6.0,
    noise_px: float = 0.5,
    mag_noise: float = 0.1,
    false_stars: int = 0,
    false_stars_max: Optional[int] = None,
    seed: int = 0,
) -> list[SequenceFrame]:
    """Simulate a slewing or tumbling spacecraft's frames with their truth.

    The camera turns at ``rate_deg_s`` about a random body axis (from ``seed``) with
    ``jitter_deg`` of attitude jitter per frame, at ``frame_rate_hz``; each image smears over
    ``exposure_s`` and its centroid noise grows along the smear. Frames ``blank = (start,
    stop)`` see no star (a loss of lock). False spots (``false_stars`` to ``false_stars_max``
    a frame) get catalogue-like magnitudes.
    """
    cat = resolve_catalog(catalog)
    cam = _camera(None, fov_deg, image_size)
    raw = _starid.simulate_sequence(
        cat._native,
        cam,
        _whole("frames", frames),
        _whole("seed", seed, 2**64 - 1),
        float(frame_rate_hz),
        float(rate_deg_s),
        float(jitter_deg),
        float(exposure_s),
        None if blank is None else (_whole("blank start", blank[0]), _whole("blank stop", blank[1])),
        None if mag_limit is None else float(mag_limit),
        float(noise_px),
        float(mag_noise),
        _whole("false_stars", false_stars),
        None if false_stars_max is None else _whole("false_stars_max", false_stars_max),
        True,
    )
    w, h = cam.image_size
    return [
        _frame(d, cam.fov_deg, (w, h), seed, SequenceFrame, t_s=float(d["t_s"]))
        for d in raw
    ]
