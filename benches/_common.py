"""What several benchmarks share: the contest catalogue, the catalogue a ``--catalog`` option
chooses, and the angle between two sky positions."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import starid

#: The contest catalogue (4908 stars brighter than 6.0), as the tests keep it.
CONTEST = Path(__file__).resolve().parents[1] / "tests" / "data" / "guide_catalog_4908.csv"


def catalog_arg(path: Optional[str]) -> starid.Catalog:
    """The catalogue at ``path`` when given, else the contest catalogue, else the bundled one."""
    if path:
        return starid.Catalog.load(path)
    if CONTEST.exists():
        return starid.Catalog.from_csv(CONTEST)
    return starid.Catalog.default()


def angle_rad(ra1: float, dec1: float, ra2: float, dec2: float) -> float:
    """The angle between two positions (degrees in), radians: the haversine form, accurate at tiny
    angles."""
    r1, d1, r2, d2 = map(math.radians, (ra1, dec1, ra2, dec2))
    h = math.sin((d2 - d1) / 2) ** 2 + math.cos(d1) * math.cos(d2) * math.sin((r2 - r1) / 2) ** 2
    return 2 * math.asin(min(1.0, math.sqrt(h)))
