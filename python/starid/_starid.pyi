"""Native module of starid (Rust, PyO3). Use the public API in ``starid`` instead."""

from os import PathLike
from typing import Any, Optional, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "Catalog",
    "CatalogError",
    "Identification",
    "PointingFit",
    "BoresightSolution",
    "Calibration",
    "Camera",
    "IdentifyConfig",
    "InvalidInputError",
    "StaridError",
    "Tracker",
    "PendingSearch",
    "GUIDE_MAX_TRIALS",
    "CONFIRM_UNSEEN_FRAMES",
    "FOCAL_LEARN_MIN_FRAMES",
    "INCONSISTENT_RMS_PX",
    "__version__",
    "guide_field_counts",
    "guide_fov_for_coverage",
    "guide_metrics",
    "guide_nearest_neighbours",
    "guide_qtm_triangle_count",
    "guide_select",
    "boresight_from_distances",
    "calibrate_camera",
    "choose_stars",
    "fit_pointing",
    "identify",
    "identify_frame",
    "identify_hinted",
    "identify_hinted_many",
    "identify_many",
    "identify_unknown_fov",
    "identify_unknown_fov_start",
    "identify_unknown_fov_many",
    "methods",
    "quaternion_from_radec_roll",
    "result_columns",
    "extract_centroids",
    "extract_defaults",
    "render_defaults",
    "luminance",
    "read_png",
    "simulate_image",
    "monte_carlo_distances",
    "predicted_distance_covariance",
    "simulate",
    "simulate_scene",
    "simulate_sequence",
    "set_index_cache_dir",
    "index_cache_dir",
]

__version__: str
INCONSISTENT_RMS_PX: float
GUIDE_MAX_TRIALS: int
CONFIRM_UNSEEN_FRAMES: int
FOCAL_LEARN_MIN_FRAMES: int

class StaridError(ValueError):
    """Base class of starid's own exceptions (a ValueError: each says what input is wrong)."""

class InvalidInputError(StaridError):
    """An argument is out of its domain: NaN or far off-sensor centroids, absurd settings."""

class CatalogError(StaridError):
    """A catalogue file or table is malformed."""

@final
class Catalog:
    """A star catalogue: ids, ICRS directions and magnitudes."""

    def __new__(
        cls,
        ids: npt.NDArray[np.int64],
        ra_deg: npt.NDArray[np.float64],
        dec_deg: npt.NDArray[np.float64],
        mag: npt.NDArray[np.float64],
    ) -> Catalog: ...
    @staticmethod
    def from_table_path(path: Union[str, PathLike[str]]) -> Catalog: ...
    @staticmethod
    def bundled() -> Catalog: ...
    @staticmethod
    def bundled_deep(mag_limit: float) -> Catalog: ...
    @staticmethod
    def bundled_deep_len(mag_limit: float) -> int: ...
    @staticmethod
    def bundled_len() -> int: ...
    @staticmethod
    def from_unit_vectors(
        ids: npt.NDArray[np.int64], vectors: npt.NDArray[np.float64], mag: npt.NDArray[np.float64]
    ) -> Catalog: ...
    @staticmethod
    def from_hip2_path(path: Union[str, PathLike[str]], mag_limit: float, epoch: float) -> Catalog: ...
    def filter_mag(self, mag_limit: float) -> Catalog: ...
    @property
    def ids(self) -> npt.NDArray[np.int64]: ...
    @property
    def ra_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def dec_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def mag(self) -> npt.NDArray[np.float64]: ...
    @property
    def unit_vectors(self) -> npt.NDArray[np.float64]: ...
    def index_info(self, max_angle_deg: float, magnitude_index: bool = False) -> dict[str, Any]: ...
    def method_index(self, method: str, max_angle_deg: float) -> dict[str, Any]: ...
    def _set_name(self, name: Optional[str]) -> None: ...
    def rows_of(self, ids: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]: ...
    def __len__(self) -> int: ...

@final
class IdentifyConfig:
    """Settings of identification: the one place they are written (defaults from the core)."""

    def __new__(
        cls,
        *,
        centroid_sigma_px: Optional[float] = None,
        max_false_match_prob: Optional[float] = None,
        min_matches: Optional[Any] = None,
        max_search_stars: Optional[Any] = None,
        max_hypotheses: Optional[Any] = None,
        max_pairs_visited: Optional[Any] = None,
        allow_mirrored: Optional[bool] = None,
        timeout_s: Optional[float] = None,
        method: Optional[str] = None,
        mag_offset: Optional[float] = 0.0,
        mag_tolerance: Optional[float] = None,
        brightness_order: Optional[bool] = None,
        verify: Optional[bool] = None,
        focal_check: Optional[bool] = None,
        fov_tolerance: Optional[float] = None,
        learn_zero_point: Optional[bool] = None,
        learn_noise: Optional[bool] = None,
        noise_fallback: Optional[bool] = None,
    ) -> IdentifyConfig: ...
    @staticmethod
    def names() -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def replace(self, **changes: Any) -> IdentifyConfig: ...
    def __getnewargs_ex__(self) -> tuple[tuple[()], dict[str, Any]]: ...
    def __eq__(self, value: object, /) -> bool: ...
    @property
    def centroid_sigma_px(self) -> Optional[float]: ...
    @property
    def max_false_match_prob(self) -> float: ...
    @property
    def min_matches(self) -> int: ...
    @property
    def max_search_stars(self) -> int: ...
    @property
    def max_hypotheses(self) -> int: ...
    @property
    def max_pairs_visited(self) -> int: ...
    @property
    def allow_mirrored(self) -> bool: ...
    @property
    def timeout_s(self) -> Optional[float]: ...
    @property
    def method(self) -> str: ...
    @property
    def mag_offset(self) -> Optional[float]: ...
    @property
    def mag_tolerance(self) -> float: ...
    @property
    def brightness_order(self) -> bool: ...
    @property
    def verify(self) -> bool: ...
    @property
    def focal_check(self) -> bool: ...
    @property
    def fov_tolerance(self) -> float: ...
    @property
    def learn_zero_point(self) -> bool: ...
    @property
    def learn_noise(self) -> bool: ...
    @property
    def noise_fallback(self) -> bool: ...

@final
class Camera:
    """A camera: sensor size, focal length, principal point and Brown–Conrady distortion."""

    def __new__(
        cls,
        image_size: tuple[float, float],
        fov_deg: Optional[float] = None,
        *,
        focal_length_px: Optional[float] = None,
        principal_point: Optional[tuple[float, float]] = None,
        k1: float = 0.0,
        k2: float = 0.0,
        k3: float = 0.0,
        p1: float = 0.0,
        p2: float = 0.0,
    ) -> Camera: ...
    @property
    def image_size(self) -> tuple[float, float]: ...
    @property
    def fov_deg(self) -> float: ...
    @property
    def diagonal_fov_deg(self) -> float: ...
    @property
    def focal_length_px(self) -> float: ...
    @property
    def principal_point(self) -> tuple[float, float]: ...
    @property
    def k1(self) -> float: ...
    @property
    def k2(self) -> float: ...
    @property
    def k3(self) -> float: ...
    @property
    def p1(self) -> float: ...
    @property
    def p2(self) -> float: ...
    def to_dict(self) -> dict[str, Any]: ...
    def save(self, path: Any) -> None: ...
    def project(self, vectors: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def unproject(self, xy: npt.NDArray[np.float64], mirrored: bool = False) -> npt.NDArray[np.float64]: ...
    def __getnewargs_ex__(self) -> tuple[tuple[tuple[float, float]], dict[str, Any]]: ...
    def __eq__(self, value: object, /) -> bool: ...

@final
class Calibration:
    """The camera fitted to many frames (``starid.calibrate``), with its uncertainty and residuals."""

    @property
    def camera(self) -> Camera: ...
    @property
    def start_camera(self) -> Camera: ...
    @property
    def parameters(self) -> list[str]: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def sigmas(self) -> dict[str, float]: ...
    @property
    def rms_before_px(self) -> float: ...
    @property
    def rms_px(self) -> float: ...
    @property
    def frame_rms_px(self) -> npt.NDArray[np.float64]: ...
    @property
    def residuals_px(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def inliers(self) -> list[npt.NDArray[np.bool_]]: ...
    @property
    def clipped(self) -> list[tuple[int, int]]: ...
    @property
    def n_inliers(self) -> int: ...
    @property
    def n_clipped(self) -> int: ...
    @property
    def n_frames(self) -> int: ...
    @property
    def quaternions(self) -> npt.NDArray[np.float64]: ...
    @property
    def rotation_matrices(self) -> npt.NDArray[np.float64]: ...
    @property
    def iterations(self) -> int: ...
    @property
    def time_s(self) -> float: ...
    @property
    def identified(self) -> Optional[tuple[int, int, int]]: ...
    def _with_identified(self, identified: tuple[int, int, int]) -> Calibration: ...
    def save(self, path: Any) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...

def calibrate_camera(
    frames: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], bool]],
    camera: Camera,
    *,
    focal_length: bool = True,
    principal_point: Optional[bool] = None,
    radial_terms: Optional[int] = None,
    decentering: Optional[bool] = None,
    clip_sigma: float = 3.0,
    max_iterations: int = 100,
) -> Calibration: ...

@final
class BoresightSolution:
    """One solution of ``boresight_from_distances``; immutable."""

    @property
    def ra_deg(self) -> float: ...
    @property
    def dec_deg(self) -> float: ...
    @property
    def focal_px(self) -> float: ...
    @property
    def rms_px(self) -> float: ...
    @property
    def residuals_px(self) -> npt.NDArray[np.float64]: ...
    @property
    def best(self) -> bool: ...
    @property
    def ambiguous(self) -> bool: ...
    @property
    def degenerate(self) -> bool: ...
    @property
    def condition(self) -> float: ...
    @property
    def converged(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def unit_covariance(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def inconsistent(self) -> bool: ...
    @property
    def boresight_sigma_rad_per_px(self) -> float: ...
    def boresight_sigma_arcsec(self, sigma_px: float) -> float: ...

@final
class PointingFit:
    """Attitude and camera fitted to matched stars; immutable."""

    @property
    def ra_deg(self) -> float: ...
    @property
    def dec_deg(self) -> float: ...
    @property
    def roll_deg(self) -> float: ...
    @property
    def quaternion(self) -> npt.NDArray[np.float64]: ...
    @property
    def rotation_matrix(self) -> npt.NDArray[np.float64]: ...
    @property
    def focal_px(self) -> float: ...
    @property
    def fov_deg(self) -> float: ...
    @property
    def principal_point_px(self) -> tuple[float, float]: ...
    @property
    def k1(self) -> float: ...
    @property
    def parameters(self) -> list[str]: ...
    @property
    def covariance(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def boresight_sigma_arcsec(self) -> float: ...
    @property
    def roll_sigma_arcsec(self) -> float: ...
    @property
    def focal_sigma_px(self) -> float: ...
    @property
    def sigma_px(self) -> float: ...
    @property
    def residuals_px(self) -> npt.NDArray[np.float64]: ...
    @property
    def rms_px(self) -> float: ...
    @property
    def iterations(self) -> int: ...
    @property
    def converged(self) -> bool: ...
    @property
    def mirrored(self) -> bool: ...

@final
class Identification:
    """The result of identifying one frame (immutable); see ``starid.identify``."""

    @property
    def ids(self) -> npt.NDArray[np.int64]: ...
    @property
    def ok(self) -> bool: ...
    @property
    def status(self) -> str: ...
    @property
    def method(self) -> str: ...
    @property
    def message(self) -> Optional[str]: ...
    @property
    def ra_deg(self) -> float: ...
    @property
    def dec_deg(self) -> float: ...
    @property
    def roll_deg(self) -> float: ...
    @property
    def boresight_radec_deg(self) -> tuple[float, float]: ...
    @property
    def quaternion(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def rotation_matrix(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def residuals_arcsec(self) -> npt.NDArray[np.float64]: ...
    @property
    def mirrored(self) -> bool: ...
    @property
    def hinted(self) -> bool: ...
    @property
    def verified(self) -> bool: ...
    @property
    def catalog(self) -> Optional[str]: ...
    @property
    def false_match_probability(self) -> float: ...
    @property
    def n_matched(self) -> int: ...
    @property
    def centroid_sigma_px(self) -> float: ...
    @property
    def match_radius_arcsec(self) -> float: ...
    @property
    def hypotheses(self) -> int: ...
    @property
    def time_s(self) -> float: ...
    @property
    def fov_deg(self) -> float: ...
    @property
    def focal_px(self) -> float: ...
    @property
    def focal_sigma_px(self) -> float: ...
    @property
    def learned_mag_offset(self) -> Optional[float]: ...
    @property
    def noise_step_px(self) -> float: ...
    @property
    def noise_source(self) -> str: ...
    @property
    def learned_sigma_px(self) -> Optional[float]: ...
    @property
    def k1(self) -> float: ...
    @property
    def read_s(self) -> float: ...
    @property
    def extract_s(self) -> float: ...
    def _with_times(self, read_s: float, extract_s: float) -> Identification: ...
    def _restated(
        self, status: Optional[str], time_s: float, bound_factor: float, focal_sigma_px: Optional[float] = None
    ) -> Identification: ...
    @property
    def image_size(self) -> tuple[float, float]: ...
    @property
    def principal_point(self) -> tuple[float, float]: ...
    @property
    def camera(self) -> Optional[Camera]: ...
    @property
    def xy(self) -> npt.NDArray[np.float64]: ...
    @property
    def magnitudes(self) -> Optional[npt.NDArray[np.float64]]: ...
    def _star_columns(
        self,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def table(self) -> npt.NDArray[Any]: ...
    def to_pandas(self) -> Any: ...
    def to_astropy(self) -> Any: ...
    def wcs_header(self) -> dict[str, Any]: ...
    def wcs(self) -> Any: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __reduce__(self) -> tuple[Any, tuple[Any]]: ...
    @staticmethod
    def _from_state(state: Any) -> Identification: ...
    @staticmethod
    def _invalid_input(message: str, n: int) -> Identification: ...

def identify(
    catalog: Catalog,
    xy: npt.NDArray[np.float64],
    magnitudes: Optional[npt.NDArray[np.float64]],
    camera: Camera,
    config: IdentifyConfig,
) -> Identification: ...
def identify_many(
    catalog: Catalog,
    xys: object,
    magnitudes: object,
    camera: Camera,
    config: IdentifyConfig,
    threads: Optional[int] = None,
) -> object: ...
def simulate(
    catalog: Catalog,
    fov_deg: float,
    width_px: float,
    height_px: float,
    seed: int,
    attitude_deg: Optional[tuple[float, float, float]] = None,
    mag_limit: Optional[float] = None,
    noise_px: float = 0.0,
    mag_noise: float = 0.0,
    false_stars: int = 0,
    drop_fraction: float = 0.0,
    mirrored: bool = False,
    radial_k1: float = 0.0,
    camera: Optional[Camera] = None,
) -> dict[str, Any]: ...
def simulate_scene(catalog: Catalog, family: str, seed: int) -> dict[str, Any]: ...
def methods() -> list[tuple[str, str]]: ...
def guide_select(
    catalog: Catalog,
    method: str,
    *,
    mag_limit: Optional[float] = None,
    separation_deg: Optional[float] = None,
    merge: bool = False,
    cell_deg: Optional[float] = None,
    level: Optional[int] = None,
) -> Catalog: ...
def guide_metrics(
    catalog: Catalog, fov_deg: float, trials: int, seed: int, field: str, k_max: int = 10
) -> dict[str, Any]: ...
def guide_fov_for_coverage(
    catalog: Catalog,
    p: float,
    k: int,
    field: str,
    trials: int,
    seed: int,
    lo_deg: float,
    hi_deg: float,
    tol_deg: float,
) -> float: ...
def guide_qtm_triangle_count(level: int) -> int: ...
def guide_field_counts(
    catalog: Catalog, fov_deg: float, trials: int, seed: int, field: str
) -> npt.NDArray[np.uint64]: ...
def guide_nearest_neighbours(catalog: Catalog) -> npt.NDArray[np.float64]: ...
def boresight_from_distances(
    radec_deg: npt.NDArray[np.float64],
    distances_px: npt.NDArray[np.float64],
    focal_px: Optional[float] = None,
    focal_range_px: Optional[tuple[float, float]] = None,
) -> list[BoresightSolution]: ...
def fit_pointing(
    radec_deg: npt.NDArray[np.float64],
    xy: npt.NDArray[np.float64],
    width_px: float,
    height_px: float,
    focal_px: Optional[float],
    fit_focal: bool,
    fit_principal_point: bool,
    fit_k1: bool,
    mirrored: bool,
    sigma_px: Optional[float],
) -> PointingFit: ...
def predicted_distance_covariance(
    offsets_px: npt.NDArray[np.float64], focal_px: float, sigma_px: float, fit_focal: bool
) -> Optional[npt.NDArray[np.float64]]: ...
def choose_stars(
    offsets_px: npt.NDArray[np.float64], focal_px: float, count: int, fit_focal: bool
) -> tuple[list[int], float]: ...
def monte_carlo_distances(
    offsets_px: npt.NDArray[np.float64],
    focal_px: float,
    sigma_px: float,
    fit_focal: bool,
    trials: int,
    seed: int,
) -> dict[str, Any]: ...
def identify_unknown_fov(
    catalog: Catalog,
    xy: npt.NDArray[np.float64],
    magnitudes: Optional[npt.NDArray[np.float64]],
    width_px: float,
    height_px: float,
    fov_lo_deg: float,
    fov_hi_deg: float,
    config: IdentifyConfig,
) -> Identification: ...
@final
class PendingSearch:
    def cancel(self) -> None: ...
    def result(self) -> Identification: ...

def identify_unknown_fov_start(
    catalog: Catalog,
    xy: npt.NDArray[np.float64],
    magnitudes: Optional[npt.NDArray[np.float64]],
    width_px: float,
    height_px: float,
    fov_lo_deg: float,
    fov_hi_deg: float,
    config: IdentifyConfig,
) -> PendingSearch: ...
def identify_unknown_fov_many(
    catalog: Catalog,
    xys: list[npt.NDArray[np.float64]],
    magnitudes: list[Optional[npt.NDArray[np.float64]]],
    width_px: float,
    height_px: float,
    fov_lo_deg: float,
    fov_hi_deg: float,
    config: IdentifyConfig,
    threads: Optional[int] = None,
) -> list[Identification]: ...
def identify_hinted_many(
    catalog: Catalog,
    xys: list[npt.NDArray[np.float64]],
    magnitudes: list[Optional[npt.NDArray[np.float64]]],
    camera: Camera,
    config: IdentifyConfig,
    hints: list[Optional[tuple[list[float], Optional[bool]]]],
    uncertainty_deg: float,
    fallback: bool,
    threads: Optional[int] = None,
) -> list[Identification]: ...

def identify_frame(
    catalog: Catalog,
    xy: object,
    magnitudes: object,
    camera: Camera,
    config: IdentifyConfig,
    hint: object,
    hint_uncertainty_deg: object,
    hint_fallback: object,
) -> object: ...
def identify_hinted(
    catalog: Catalog,
    xy: npt.NDArray[np.float64],
    magnitudes: Optional[npt.NDArray[np.float64]],
    camera: Camera,
    config: IdentifyConfig,
    hint_wxyz: list[float],
    uncertainty_deg: float,
    mirrored: Optional[bool],
    fallback: bool,
) -> Identification: ...
def quaternion_from_radec_roll(ra_rad: float, dec_rad: float, roll_rad: float) -> list[float]: ...
def simulate_sequence(
    catalog: Catalog,
    camera: Camera,
    frames: int,
    seed: int,
    frame_rate_hz: float = 10.0,
    rate_deg_s: float = 1.0,
    jitter_deg: float = 0.001,
    exposure_s: float = 0.02,
    blank: Optional[tuple[int, int]] = None,
    mag_limit: Optional[float] = None,
    noise_px: float = 0.5,
    mag_noise: float = 0.1,
    false_stars: int = 0,
    false_stars_max: Optional[int] = None,
    catalog_false_mags: bool = True,
) -> list[dict[str, Any]]: ...

@final
class Tracker:
    """The core tracker with its solver and camera."""

    def __new__(
        cls,
        catalog: Catalog,
        camera: Camera,
        config: IdentifyConfig,
        max_rate_deg_s: float,
        min_uncertainty_deg: float,
        fallback: bool,
        confirm_new_stars: bool = False,
        confirm_unseen_frames: Optional[int] = ...,
    ) -> Tracker: ...
    def update(
        self, xy: npt.NDArray[np.float64], t_s: float, magnitudes: Optional[npt.NDArray[np.float64]] = None
    ) -> dict[str, Any]: ...
    def reset(self) -> None: ...
    @property
    def has_lock(self) -> bool: ...
def result_columns(results: list[Identification], spots: bool = False) -> dict[str, Any]: ...
def luminance(image: npt.NDArray[Any]) -> npt.NDArray[np.float32]: ...
def read_png(path: Union[str, PathLike[str]], max_pixels: int) -> npt.NDArray[Any]: ...
def extract_centroids(
    image: npt.NDArray[Any],
    dark: Optional[npt.NDArray[np.float32]] = None,
    flat: Optional[npt.NDArray[np.float32]] = None,
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
) -> dict[str, Any]: ...
def extract_defaults() -> dict[str, Any]: ...
def simulate_image(
    catalog: Catalog,
    camera: Camera,
    seed: int,
    mag_limit: Optional[float] = None,
    false_stars: int = 0,
    psf_sigma_px: Optional[float] = None,
    zero_point_e: Optional[float] = None,
    background_e: Optional[float] = None,
    gradient_e: Optional[float] = None,
    read_noise_e: Optional[float] = None,
    hot_pixels: Optional[int] = None,
    hot_pixel_e: Optional[float] = None,
    trail: Optional[tuple[tuple[float, float, float, float], float]] = None,
    full_well_e: Optional[float] = None,
    gain_e_per_dn: Optional[float] = None,
    bits: Optional[int] = None,
    clip_background: Optional[bool] = None,
    foreground: Optional[float] = None,
) -> tuple[npt.NDArray[np.float32], dict[str, Any]]: ...
def render_defaults() -> dict[str, Any]: ...
def set_index_cache_dir(path: str | PathLike[str] | None) -> None: ...
def index_cache_dir() -> PathLike[str] | None: ...
