"""Shared fixtures and hypothesis profiles (STARID_HYPOTHESIS_PROFILE = dev | ci | nightly)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

import starid

settings.register_profile("dev", max_examples=25, deadline=None, print_blob=True)
settings.register_profile("ci", max_examples=50, deadline=None, print_blob=True, derandomize=True)
settings.register_profile("nightly", max_examples=2000, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("STARID_HYPOTHESIS_PROFILE", "dev"))

ROOT = Path(__file__).resolve().parent.parent
CONTEST_CATALOG = ROOT.parent / "shared" / "data" / "guide_catalog_4908.csv"


@pytest.fixture(scope="session")
def contest() -> starid.Catalog:
    """The 2019 contest's guide catalogue (4908 SKYMAP2000 stars brighter than 6.0)."""
    if not CONTEST_CATALOG.exists():
        pytest.skip(f"contest catalogue not found at {CONTEST_CATALOG}")
    return starid.Catalog.from_csv(CONTEST_CATALOG)


@pytest.fixture(scope="session")
def bundled() -> starid.Catalog:
    return starid.Catalog.default()
