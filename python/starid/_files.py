"""Files in and out, safely: inputs read only when they are regular files within a size limit,
outputs written whole to a temporary file beside the target and renamed over it, never over an
input and never through a symbolic link."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Optional, Union

from ._errors import InvalidInputError

PathLike = Union[str, "os.PathLike[str]"]

#: Largest file read as an image, a star list or a catalogue, in bytes (``STARID_MAX_FILE_BYTES``
#: raises it).
MAX_FILE_BYTES = int(os.environ.get("STARID_MAX_FILE_BYTES", 2 << 30))

_UMASK = os.umask(0o022)
os.umask(_UMASK)


def checked_input(path: PathLike, what: str = "file", max_bytes: int | None = None) -> Path:
    """``path`` if it is a regular file of at most ``max_bytes`` (default :data:`MAX_FILE_BYTES`).

    A missing file raises FileNotFoundError, a folder IsADirectoryError; a device, FIFO or
    socket, or a file over the limit, raises InvalidInputError naming it, before anything is
    read."""
    p = Path(os.fspath(path))
    try:
        st = p.stat()
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: no such {what}") from None
    if stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(f"{p}: is a directory; {what}s are read from regular files")
    if not stat.S_ISREG(st.st_mode):
        raise InvalidInputError(f"{p}: not a regular file (a device, FIFO or socket); {what}s are read from regular files")
    limit = MAX_FILE_BYTES if max_bytes is None else max_bytes
    if st.st_size > limit:
        raise InvalidInputError(
            f"{p}: {st.st_size} bytes, over the {limit}-byte limit for {what}s (STARID_MAX_FILE_BYTES raises it)"
        )
    return p


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether two paths name one file (through links, relative parts or hard links)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def refuse_overwriting(outputs: Iterable[Optional[PathLike]], inputs: Iterable[Optional[PathLike]]) -> None:
    """InvalidInputError when an output path names one of the inputs (None entries are
    skipped)."""
    sources = [src for src in inputs if src is not None]
    for out in outputs:
        if out is not None and any(same_file(out, src) for src in sources):
            raise InvalidInputError(f"{out}: is an input too; refusing to overwrite it")


def write_atomically(path: PathLike, write: Callable[[str], None], inputs: Iterable[PathLike] = ()) -> Path:
    """Write a file through ``write(temporary_path)`` and rename it to ``path``; returns the
    path written.

    The temporary file lies in the target's folder and keeps its suffix (writers that choose the
    format by it see the right one). The rename replaces ``path`` whole, so a reader never sees
    half a file, a failed write leaves the old file as it was, and a symbolic link at ``path``
    is replaced, never written through. A ``path`` that is one of ``inputs`` is refused with
    InvalidInputError before anything is written."""
    target = Path(os.fspath(path))
    refuse_overwriting([target], inputs)
    if target.is_dir():
        raise IsADirectoryError(f"{target}: is a directory")
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.", suffix="".join(target.suffixes[-1:]))
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)  # as a file opened for writing would be, not mkstemp's 0600
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target.resolve()
