"""Where pair indexes are kept across processes.

Building the pair index of a field of view takes a few hundred milliseconds; reading it back
takes a few. The core writes each index it builds (above a size worth keeping) to the index
cache directory, named by the catalogue's content and the indexed angle, and a later process
reads it instead of building it. A changed catalogue has another name, so it never reads the
files of another; a damaged file is rebuilt and replaced.

The directory is the user's cache directory (``platformdirs.user_cache_dir("starid")`` /
``indexes``: ``~/.cache/starid/indexes`` on Linux), or ``STARID_CACHE_DIR`` when that is set
(set it empty to keep nothing), or what :func:`set_index_cache_dir` says.
"""

from __future__ import annotations

import os
from pathlib import Path

import platformdirs

from . import _starid

#: Environment variable naming the index cache directory (empty: keep no index on disk).
CACHE_DIR_ENV = "STARID_CACHE_DIR"


def default_index_cache_dir() -> Path | None:
    """``STARID_CACHE_DIR`` when set (None when empty), else the user's cache directory."""
    env = os.environ.get(CACHE_DIR_ENV)
    if env is not None:
        return Path(env).expanduser() if env.strip() else None
    return Path(platformdirs.user_cache_dir("starid", appauthor=False)) / "indexes"


def set_index_cache_dir(path: str | os.PathLike[str] | None) -> None:
    """Keep pair indexes in ``path`` from now on (created when first written); ``None`` keeps
    none on disk. Indexes already in memory stay there.

    Examples
    --------
    >>> import starid, tempfile
    >>> before = starid.index_cache_dir()
    >>> with tempfile.TemporaryDirectory() as d:
    ...     starid.set_index_cache_dir(d)
    ...     starid.index_cache_dir() == Path(d)
    True
    >>> starid.set_index_cache_dir(before)
    """
    _starid.set_index_cache_dir(None if path is None else os.fspath(path))


def index_cache_dir() -> Path | None:
    """The directory pair indexes are kept in, or None when none are kept."""
    d = _starid.index_cache_dir()
    return None if d is None else Path(d)


def index_cache_files() -> list[tuple[Path, int]]:
    """The index files in the cache directory with their sizes in bytes, largest first."""
    d = index_cache_dir()
    if d is None or not d.is_dir():
        return []
    files = [(p, p.stat().st_size) for p in d.glob("pairs-v*.idx") if p.is_file()]
    return sorted(files, key=lambda f: -f[1])


def clear_index_cache() -> int:
    """Delete the index files in the cache directory (only those: nothing else there is
    touched); returns how many. Later calls build their indexes again."""
    files = index_cache_files()
    for p, _ in files:
        p.unlink(missing_ok=True)
    return len(files)


set_index_cache_dir(default_index_cache_dir())
