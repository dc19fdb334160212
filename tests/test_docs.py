"""Every docstring example of the public modules runs and prints what it shows."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["starid", "starid._catalog", "starid._identify", "starid._simulate", "starid._batch", "starid.guide", "starid.pointing", "starid.starlist", "starid.tracking", "starid.images", "starid.wcs"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
