"""Shared fixtures and hypothesis profiles (STARID_HYPOTHESIS_PROFILE = dev | ci | nightly)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from hypothesis import settings

# The tests keep their pair indexes in a directory of their own, not the user's cache.
_INDEX_CACHE = tempfile.TemporaryDirectory(prefix="starid-test-indexes-")
os.environ["STARID_CACHE_DIR"] = _INDEX_CACHE.name

import starid  # noqa: E402

settings.register_profile("dev", max_examples=25, deadline=None, print_blob=True)
settings.register_profile("ci", max_examples=50, deadline=None, print_blob=True, derandomize=True)
settings.register_profile("nightly", max_examples=2000, deadline=None, print_blob=True)  # fuzz tests: 10 000
settings.load_profile(os.environ.get("STARID_HYPOTHESIS_PROFILE", "dev"))

ROOT = Path(__file__).resolve().parent.parent
#: The contest catalogue is public data, kept with the tests so that they run on a fresh clone.
CONTEST_CATALOG = ROOT / "tests" / "data" / "guide_catalog_4908.csv"


@pytest.fixture(scope="session")
def contest() -> starid.Catalog:
    """The 2019 contest's guide catalogue (4908 SKYMAP2000 stars brighter than 6.0)."""
    return starid.Catalog.from_csv(CONTEST_CATALOG)


@pytest.fixture(scope="session")
def bundled() -> starid.Catalog:
    return starid.Catalog.default()


_skipped: list[str] = []


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if report.skipped:
        _skipped.append(report.nodeid)


def pytest_collectreport(report: pytest.CollectReport) -> None:
    # A module skipped while it is collected (importorskip at its top) loses every test in it.
    if report.skipped:
        _skipped.append(report.nodeid)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Every optional extra is installed for the tests (``pip install .[test]``): a skipped
    test means something is missing, so it fails the run unless STARID_ALLOW_SKIPS is set."""
    if _skipped and not os.environ.get("STARID_ALLOW_SKIPS") and exitstatus in (0, 5):
        print(f"\n{len(_skipped)} test(s) skipped (set STARID_ALLOW_SKIPS=1 to allow): {', '.join(_skipped)}")
        session.exitstatus = 1


@pytest.fixture
def ctrl_c() -> Iterator[Callable[[float], None]]:
    """``ctrl_c(after_s)``: Ctrl-C pressed ``after_s`` seconds from now, as in a terminal.

    A process started with SIGINT ignored (a background job of a non-interactive shell, as CI
    may run) has no KeyboardInterrupt handler, and ``_thread.interrupt_main`` is then dropped:
    the handler a terminal's Python has is installed for the test and restored after it."""
    import _thread
    import signal
    import threading

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timers: list[threading.Timer] = []

    def press(after_s: float) -> None:
        t = threading.Timer(after_s, _thread.interrupt_main)
        timers.append(t)
        t.start()

    try:
        yield press
    finally:
        for t in timers:
            t.cancel()
        signal.signal(signal.SIGINT, previous)
