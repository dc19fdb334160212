"""Reading star lists (centroid files): CSV or whitespace text with ``label,x,y[,mag]`` or ``x,y``."""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np
import numpy.typing as npt

from ._errors import InvalidInputError
from ._files import checked_input

#: Longest line of a star list: a row holds a label, two coordinates and a magnitude (and a
#: few more columns at most).
MAX_LINE_CHARS = 4096

__all__ = ["StarList", "read_star_list"]

_X = ("x", "x_px", "col", "column", "xc", "x_centroid")
_Y = ("y", "y_px", "row", "yc", "y_centroid")
_LABEL = ("label", "id", "name", "star", "index", "#")
_MAG = ("mag", "magnitude", "instrument_mag", "inst_mag")


@dataclass(frozen=True)
class StarList:
    """Centroids read from a file: labels, (N, 2) pixel coordinates, optional magnitudes."""

    labels: list[str]
    xy: npt.NDArray[np.float64]
    magnitudes: Optional[npt.NDArray[np.float64]]


def read_star_list(path: Union[str, "os.PathLike[str]"]) -> StarList:
    """Read a star list.

    Accepted layouts (CSV, or whitespace/tab separated; blank lines and ``#`` comments skipped):

    - a header naming the columns ``x`` and ``y`` (and optionally ``label``/``id`` and ``mag``);
    - no header with 2 columns ``x y``, 3 columns ``label x y``, or 4 columns ``label x y mag``.

    Labels default to the row numbers 0, 1, 2, ...

    Raises
    ------
    InvalidInputError (a ValueError)
        When the file holds no centroid or a row is malformed (the message names the line).

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
    ...     _ = f.write("label,x,y\\nA,10.5,20\\nB,30,40.25\\n")
    >>> s = read_star_list(f.name); os.remove(f.name)
    >>> s.labels, s.xy.tolist()
    (['A', 'B'], [[10.5, 20.0], [30.0, 40.25]])
    """
    path = os.fspath(checked_input(path, "star list"))
    with open(path, encoding="utf-8-sig", newline="") as fh:
        text = fh.read()
    lines = [(n + 1, line.strip()) for n, line in enumerate(text.splitlines())]
    rows = [(n, line) for n, line in lines if line and not line.startswith("#")]
    if not rows:
        raise InvalidInputError(f"{path}: holds no centroids")
    for n, line in rows:
        if len(line) > MAX_LINE_CHARS:
            raise InvalidInputError(f"{path}: line {n} has {len(line)} characters: not a star-list row (label, x, y, mag)")
    comma = "," in rows[0][1]

    def split(line: str) -> list[str]:
        # CSV goes through the csv module: a quoted label may hold a comma ("Sirius, a CMa").
        parts = next(csv.reader([line], skipinitialspace=True)) if comma else line.split()
        return [p.strip() for p in parts]

    first = split(rows[0][1])
    cols: dict[str, int]
    if all(_is_number(f) for f in first[-2:]) and (len(first) < 3 or _is_number(first[1])):
        ncol = len(first)
        if ncol == 2:
            cols = {"x": 0, "y": 1}
        elif ncol == 3:
            cols = {"label": 0, "x": 1, "y": 2}
        elif ncol >= 4:
            cols = {"label": 0, "x": 1, "y": 2, "mag": 3}
        else:
            raise InvalidInputError(f"{path}:{rows[0][0]}: expected columns x,y or label,x,y[,mag], found {ncol}")
        data = rows
    else:
        names = [f.lower() for f in first]
        cols = {}
        for key, aliases in (("x", _X), ("y", _Y), ("label", _LABEL), ("mag", _MAG)):
            hit = next((names.index(a) for a in aliases if a in names), None)
            if hit is not None:
                cols[key] = hit
        if "x" not in cols or "y" not in cols:
            raise InvalidInputError(f"{path}:{rows[0][0]}: the header {first} names no x and y columns")
        data = rows[1:]
        if not data:
            raise InvalidInputError(f"{path}: holds a header but no centroids")
    need = max(cols.values()) + 1
    labels: list[str] = []
    xy: list[tuple[float, float]] = []
    mags: list[float] = []
    for n, line in data:
        f = split(line)
        if len(f) < need:
            raise InvalidInputError(f"{path}:{n}: expected at least {need} fields, found {len(f)}")
        try:
            x, y = float(f[cols["x"]]), float(f[cols["y"]])
            if "mag" in cols:
                mags.append(float(f[cols["mag"]]))
        except ValueError as e:
            raise InvalidInputError(f"{path}:{n}: {e}") from None
        xy.append((x, y))
        labels.append(f[cols["label"]] if "label" in cols else str(len(labels)))
    return StarList(
        labels=labels,
        xy=np.asarray(xy, dtype=np.float64).reshape(-1, 2),
        magnitudes=np.asarray(mags, dtype=np.float64) if "mag" in cols else None,
    )


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True
