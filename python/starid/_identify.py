"""``starid.identify``: the one entry point for a frame, whatever it is given (centroids, spots
extracted by starid, an image array or file), with the field of view known, roughly known or
unknown, with an attitude hint or without (batches: ``_batch``)."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from . import _starid
from ._args import (
    _CAMERAS,
    _CONFIGS,
    _DEFAULT_CONFIG,
    _UNKNOWN_ZERO_POINT_CONFIG,
    _UNSET,
    Identification,
    _camera,
    _config,
    _from_pixel_origin,
    _is_image,
)
from ._catalog import Catalog, CatalogLike, resolve_catalog_for
from ._centroids import Centroids
from ._errors import InvalidInputError
from ._solve import identify_centroids
from .images import identify_image

__all__ = ["identify"]


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
        How far off ``fov_deg`` may be, relative to the true field (default 0.1: ``fov_deg``
        within ±10 % of it, so the field between ``fov_deg / 1.1`` and ``fov_deg / 0.9``).
        Where the given field finds no solution, or one its residuals or unmatched stars put in
        doubt, the frame is searched with the focal length unknown within the tolerance, and the
        field found reported. 0 (or ``focal_check=False``) holds the field as given: for cameras
        known exactly, whose frames then cost no search beyond it. A calibrated camera
        (principal point off the centre, distortion) is held as given.
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
        if magnitudes is not None:
            raise InvalidInputError("an image's magnitudes come from its spots: do not pass magnitudes=")
        return identify_image(
            xy, catalog, fov_deg, image_size=image_size, camera=camera, fov_range_deg=fov_range_deg,
            attitude_hint=attitude_hint, hint_uncertainty_deg=hint_uncertainty_deg, hint_fallback=hint_fallback,
            config=config, **settings,
        ).identification
    return identify_centroids(
        xy, catalog, fov_deg, image_size, magnitudes, camera=camera, fov_range_deg=fov_range_deg,
        attitude_hint=attitude_hint, hint_uncertainty_deg=hint_uncertainty_deg, hint_fallback=hint_fallback,
        config=config, **settings,
    )
