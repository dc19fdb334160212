"""Fuzzing with hostile files: truncated, corrupted, empty, of the wrong format, a FIFO, a
device, a folder, a symbolic link; through the readers, a batch and every CLI subcommand.

Whatever the file: a typed exception or a result, never a panic or a raw reader error; a batch
returns one result per input; the CLI exits 0, 1 or 2 and never overwrites an input. Example
counts follow the hypothesis profile (the nightly one runs thousands)."""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

import starid
from starid.cli import main

FUZZ = settings(
    max_examples=3_000 if os.environ.get("STARID_HYPOTHESIS_PROFILE") == "nightly" else 40,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    deadline=None,
)

#: What a reader may raise for a hostile file: typed, naming what is wrong.
TYPED = (starid.StaridError, FileNotFoundError, IsADirectoryError, UnicodeDecodeError, ImportError)


def _good_files(d: Path) -> dict[str, bytes]:
    """A good file of each kind, as bytes."""
    from astropy.io import fits

    img, _ = starid.simulate_image(None, 12.0, (160, 120), seed=2)
    out: dict[str, bytes] = {}
    Image.fromarray(np.clip(img, 0, 65535).astype(np.uint16)).save(d / "g.png")
    Image.fromarray(np.clip(img / 64, 0, 255).astype(np.uint8)).save(d / "g.jpg")
    fits.PrimaryHDU(img.astype(np.float32)).writeto(d / "g.fits")
    f = starid.simulate(seed=3, noise_px=0.1)
    (d / "g.csv").write_text("label,x,y,mag\n" + "".join(f"s{i},{x},{y},{m}\n" for i, ((x, y), m) in enumerate(zip(f.xy, f.magnitudes))))
    (d / "cat.csv").write_text("id,ra_deg,dec_deg,mag\n" + "".join(f"{i},{i * 7 % 360},{(i * 13) % 180 - 90},{i % 6}\n" for i in range(50)))
    for name in ("g.png", "g.jpg", "g.fits", "g.csv", "cat.csv"):
        out[name] = (d / name).read_bytes()
    return out


GOOD = _good_files(Path(tempfile.mkdtemp(prefix="starid-fuzz-")))

#: How a good file is made hostile: (kind, fraction or seed).
damage = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 1.0)),
    st.tuples(st.just("flip"), st.integers(0, 2**32 - 1)),
    st.tuples(st.just("garbage"), st.integers(0, 2**32 - 1)),
    st.tuples(st.just("empty"), st.just(0)),
    st.tuples(st.just("swap"), st.integers(0, 4)),
)


def _hostile(d: Path, source: str, name: str, how: tuple[str, Any]) -> Path:
    """``GOOD[source]`` damaged as ``how`` says, written as ``d / name``."""
    data = GOOD[source]
    kind, arg = how
    rng = np.random.default_rng(arg if isinstance(arg, int) else 0)
    if kind == "truncate":
        data = data[: int(len(data) * arg)]
    elif kind == "flip":
        b = bytearray(data)
        for k in rng.integers(0, len(b), 1 + len(b) // 200):
            b[k] ^= int(rng.integers(1, 256))
        data = bytes(b)
    elif kind == "garbage":
        data = rng.integers(0, 256, int(rng.integers(0, 4096)), dtype=np.uint8).tobytes()
    elif kind == "empty":
        data = b""
    else:  # another kind's bytes under this name
        data = list(GOOD.values())[arg]
    p = d / name
    p.write_bytes(data)
    return p


def _digest(paths: list[Path]) -> dict[Path, str]:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in paths if p.is_file()}


def _typed(f: Callable[..., Any], *args: Any, **kw: Any) -> Any:
    try:
        return f(*args, **kw)
    except TYPED:
        return None
    except BaseException as e:  # a panic, a raw reader error, anything else fails
        if isinstance(e, KeyboardInterrupt):
            raise
        raise AssertionError(f"{type(e).__name__}: {e}") from e


@FUZZ
@given(source=st.sampled_from(["g.png", "g.jpg", "g.fits", "g.csv", "cat.csv"]), how=damage)
def test_readers_raise_typed_errors_for_hostile_files(source: str, how: tuple[str, Any]) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = _hostile(Path(d), source, source, how)
        if source.endswith((".png", ".jpg", ".fits")):
            _typed(starid.read_image, p)
            _typed(starid.extract_centroids, p)
        elif source == "g.csv":
            _typed(starid.read_star_list, p)
        else:
            _typed(starid.Catalog.load, p)


@FUZZ
@given(
    hows=st.lists(st.tuples(st.sampled_from(["g.png", "g.jpg", "g.fits"]), damage), min_size=1, max_size=4),
    fov=st.sampled_from([12.0, None]),
)
def test_a_batch_of_hostile_images_returns_one_result_each(hows: list[tuple[str, Any]], fov: Any) -> None:
    with tempfile.TemporaryDirectory() as d:
        paths = [Path(d) / "good.png"]
        paths[0].write_bytes(GOOD["g.png"])
        paths += [_hostile(Path(d), src, f"h{k}{Path(src).suffix}", how) for k, (src, how) in enumerate(hows)]
        res = starid.identify_many(paths, fov_deg=fov)
        assert len(res) == len(paths)
        for p, r in zip(paths[1:], res[1:]):
            if r.status == "invalid_input":
                assert r.message is not None and p.name in r.message


@FUZZ
@given(
    source=st.sampled_from(["g.png", "g.jpg", "g.fits", "g.csv"]),
    how=damage,
    command=st.sampled_from(["identify", "identify-json", "identify-wcs", "identify-annotate", "track", "simulate", "guide", "catalog"]),
    out_is_input=st.booleans(),
    special=st.sampled_from([None, "fifo", "dir", "devnull", "link"]),
)
def test_cli_subcommands_survive_hostile_files(
    source: str, how: tuple[str, Any], command: str, out_is_input: bool, special: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    with tempfile.TemporaryDirectory() as d:
        dd = Path(d)
        good = dd / "good.csv"
        good.write_bytes(GOOD["g.csv"])
        cat = dd / "cat.csv"
        cat.write_bytes(GOOD["cat.csv"])
        bad = _hostile(dd, source, "bad" + Path(source).suffix, how)
        if special == "fifo":
            bad = dd / "fifo.csv"
            os.mkfifo(bad)
        elif special == "dir":
            bad = dd / "folder.png"
            bad.mkdir()
        elif special == "devnull":
            bad = Path("/dev/null")
        elif special == "link":
            link = dd / "link.png"
            link.symlink_to(bad)
            bad = link
        inputs = [good, bad, cat]
        before = _digest([good, cat] + ([bad] if bad.is_file() and bad.parent == dd else []))
        out = bad if out_is_input else dd / "out.fits"
        size = ["--size", "512x512"]
        argv = {
            "identify": ["identify", str(good), str(bad), "--fov-deg", "12", *size],
            "identify-json": ["identify", str(bad), str(good), "--fov-deg", "12", *size, "--json"],
            "identify-wcs": ["identify", str(bad), "--fov-deg", "12", *size, "--wcs", str(out)],
            "identify-annotate": ["identify", str(bad), "--fov-deg", "12", "--annotate", str(out.with_suffix(".png") if not out_is_input else out)],
            "track": ["track", str(good), str(bad), str(good), "--fov-deg", "12", *size, "--frame-rate-hz", "10"],
            "simulate": ["simulate", str(out if out_is_input else dd / "sim.csv"), "--catalog", str(bad if out_is_input else cat)],
            "guide": ["guide", "select", str(dd / "sel.csv"), "--catalog", str(bad), "--method", "magnitude", "--mag-limit", "3"],
            "catalog": ["catalog", "--catalog", str(bad)],
        }[command]
        try:
            code = main(argv)
        except SystemExit as e:  # argparse refusing an argument
            code = int(e.code or 0)
        except BaseException as e:
            if isinstance(e, KeyboardInterrupt):
                raise
            raise AssertionError(f"{argv}: {type(e).__name__}: {e}") from e
        capsys.readouterr()
        assert code in (0, 1, 2), argv
        assert _digest(list(before)) == before, f"{argv} changed an input"
        del inputs
