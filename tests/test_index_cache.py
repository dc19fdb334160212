"""Pair indexes kept on disk: read back by a new process, never by another catalogue."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import starid
from starid.cli import main

from conftest import CONTEST_CATALOG

FOV, SIZE = 20.0, (1024, 1024)


@pytest.fixture
def cache_dir(tmp_path: Path):
    before = starid.index_cache_dir()
    starid.set_index_cache_dir(tmp_path)
    yield tmp_path
    starid.set_index_cache_dir(before)


def _catalog(mag_shift: float = 0.0) -> starid.Catalog:
    """A new catalogue object (with no index in memory) of the contest catalogue's content."""
    c = starid.Catalog.from_csv(CONTEST_CATALOG)
    mag = c.mag.copy()
    mag[100] += mag_shift
    return starid.Catalog(c.ids, c.ra_deg, c.dec_deg, mag)


def test_an_index_built_once_is_read_back_by_the_next_catalogue_of_that_content(cache_dir: Path) -> None:
    first = _catalog().index_info(FOV, SIZE)
    assert first["index_file"] is not None and Path(first["index_file"]).parent == cache_dir
    assert [p for p, _ in starid.index_cache_files()] == [Path(first["index_file"])]
    stamp = os.stat(first["index_file"]).st_mtime_ns
    again = _catalog().index_info(FOV, SIZE)
    # Read, not rebuilt and rewritten: the same file, untouched, the same index.
    assert again["index_file"] == first["index_file"]
    assert os.stat(first["index_file"]).st_mtime_ns == stamp
    assert {k: again[k] for k in ("pairs", "bright_pairs", "max_angle_deg")} == {
        k: first[k] for k in ("pairs", "bright_pairs", "max_angle_deg")
    }
    cat = _catalog()
    frame = starid.simulate(fov_deg=FOV, image_size=SIZE, seed=3, noise_px=0.2, catalog=cat)
    res = starid.identify(frame.xy, fov_deg=FOV, image_size=SIZE, catalog=cat)
    assert res.ok and res.ids.tolist() == frame.true_ids.tolist()


def test_a_changed_catalogue_never_reads_the_index_of_another(cache_dir: Path) -> None:
    first = _catalog().index_info(FOV, SIZE)
    changed = _catalog(mag_shift=0.01).index_info(FOV, SIZE)
    assert changed["index_file"] != first["index_file"]
    assert len(starid.index_cache_files()) == 2


def test_a_damaged_index_file_is_rebuilt(cache_dir: Path) -> None:
    path = Path(_catalog().index_info(FOV, SIZE)["index_file"])
    good = path.read_bytes()
    bad = bytearray(good)
    bad[len(bad) // 2] ^= 0xFF
    path.write_bytes(bytes(bad))
    info = _catalog().index_info(FOV, SIZE)
    assert Path(info["index_file"]) == path and path.read_bytes() == good
    assert starid.clear_index_cache() == 1 and starid.index_cache_files() == []


def test_no_cache_directory_keeps_nothing(cache_dir: Path) -> None:
    starid.set_index_cache_dir(None)
    assert starid.index_cache_dir() is None
    assert _catalog().index_info(FOV, SIZE)["index_file"] is None
    assert list(cache_dir.iterdir()) == []


def test_an_unwritable_cache_directory_only_means_nothing_is_kept(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    before = starid.index_cache_dir()
    try:
        starid.set_index_cache_dir(blocker / "indexes")
        info = _catalog().index_info(FOV, SIZE)
        assert info["index_file"] is None and info["pairs"] > 0
    finally:
        starid.set_index_cache_dir(before)
    assert blocker.read_text() == "not a directory"


def test_a_new_process_reads_the_index_the_last_one_wrote(tmp_path: Path) -> None:
    script = (
        "import starid, sys\n"
        f"c = starid.Catalog.from_csv({str(CONTEST_CATALOG)!r})\n"
        f"print(c.index_info({FOV}, {SIZE})['index_file'])\n"
    )
    env = dict(os.environ, STARID_CACHE_DIR=str(tmp_path))
    run = lambda: subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    first, second = run().stdout.strip(), run().stdout.strip()
    assert Path(first).parent == tmp_path and second == first
    # Set empty, the variable keeps nothing.
    env["STARID_CACHE_DIR"] = ""
    assert run().stdout.strip() == "None"
    assert np.array_equal(sorted(p.name for p in tmp_path.iterdir()), [Path(first).name])


def test_the_command_line_reports_and_clears_the_index_cache(
    cache_dir: Path, tmp_path_factory: pytest.TempPathFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    # A file of its own, so that no catalogue read earlier holds its index in memory.
    stars = tmp_path_factory.mktemp("catalogue") / "stars.csv"
    stars.write_bytes(CONTEST_CATALOG.read_bytes())
    args = ["catalog", str(stars), "--fov-deg", str(FOV), "--size", f"{SIZE[0]}x{SIZE[1]}"]
    assert main(args) == 0
    out = capsys.readouterr().out
    (path,) = [p for p, _ in starid.index_cache_files()]
    assert f"index file {path}" in out and "1 file(s)" in out
    assert main([*args, "--clear-index-cache"]) == 0
    out = capsys.readouterr().out
    assert "deleted 1 index file(s)" in out and "0 file(s)" in out and not path.exists()
