"""starid: lost-in-space star identification.

Tell a star tracker which catalogue stars its centroids are and where it points:

>>> import starid
>>> frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=11, noise_px=0.2)
>>> res = starid.identify(frame.xy, fov_deg=12.0, image_size=(512, 512))
>>> res.ok
True

The heavy lifting (k-vector pair index, Pyramid search, verification, attitude) is done by
the Rust core; see ARCHITECTURE.md.
"""

from . import guide, plot, pointing, tracking, wcs
from .calibration import calibrate, load_camera, save_camera
from ._catalog import BUNDLED_DEPTHS, MAX_STARS_PER_FIELD, MIN_STARS_PER_FIELD, Catalog, catalog_for
from ._errors import CatalogError, InvalidInputError, StaridError
from ._index_cache import clear_index_cache, index_cache_dir, index_cache_files, set_index_cache_dir
from ._batch import identify_many
from ._args import METHODS, Camera, Identification, IdentifyConfig
from ._identify import identify
from ._simulate import SCENE_FAMILIES, Frame, simulate, simulate_scene
from ._unknown_field import DEFAULT_FOV_RANGE_DEG
from ._starid import __version__
from .images import Centroids, ImageIdentification, extract_centroids, identify_image, read_image, simulate_image
from .starlist import read_star_list
from .tracking import SequenceFrame, Tracker, TrackStep, simulate_sequence, track

__all__ = [
    "DEFAULT_FOV_RANGE_DEG",
    "Camera",
    "calibrate",
    "load_camera",
    "save_camera",
    "MIN_STARS_PER_FIELD",
    "MAX_STARS_PER_FIELD",
    "BUNDLED_DEPTHS",
    "catalog_for",
    "clear_index_cache",
    "index_cache_dir",
    "index_cache_files",
    "set_index_cache_dir",
    "Centroids",
    "ImageIdentification",
    "Catalog",
    "CatalogError",
    "Frame",
    "Identification",
    "SequenceFrame",
    "TrackStep",
    "Tracker",
    "IdentifyConfig",
    "InvalidInputError",
    "METHODS",
    "SCENE_FAMILIES",
    "StaridError",
    "__version__",
    "extract_centroids",
    "guide",
    "identify_image",
    "read_image",
    "simulate_image",
    "identify",
    "identify_many",
    "plot",
    "pointing",
    "read_star_list",
    "simulate",
    "simulate_scene",
    "simulate_sequence",
    "track",
    "tracking",
    "wcs",
]
