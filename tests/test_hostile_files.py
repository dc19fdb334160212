"""Hostile files: a bad file is a bad result, never a lost batch; outputs never destroy inputs;
reads are bounded; every frame of a track is reported."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import starid
from starid.cli import main

FOV, SIZE = 12.0, (640, 480)


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A 16-bit PNG, an 8-bit JPEG, a truncated FITS file and a star list, all of one camera."""
    from astropy.io import fits

    d = tmp_path_factory.mktemp("frames")
    img, _ = starid.simulate_image(None, FOV, SIZE, seed=21)
    png, jpg, trunc, csv = d / "good16.png", d / "good8.jpg", d / "trunc.fits", d / "frame.csv"
    Image.fromarray(np.clip(img, 0, 65535).astype(np.uint16)).save(png)
    Image.fromarray(np.clip(img / img.max() * 255 * 4, 0, 255).astype(np.uint8)).save(jpg, quality=95)
    fits.PrimaryHDU(img.astype(np.float32)).writeto(trunc)
    trunc.write_bytes(trunc.read_bytes()[: 2880 + 10_000])  # the header whole, most pixels gone
    f = starid.simulate(None, FOV, SIZE, seed=5, noise_px=0.1)
    csv.write_text("label,x,y\n" + "".join(f"s{i},{x},{y}\n" for i, (x, y) in enumerate(f.xy)))
    return {"png": png, "jpg": jpg, "trunc": trunc, "csv": csv}


def test_a_truncated_fits_file_is_a_typed_error_naming_it(frames: dict[str, Path]) -> None:
    with pytest.raises(starid.InvalidInputError, match="trunc.fits"):
        starid.read_image(frames["trunc"])


def test_a_bad_file_in_a_batch_is_one_bad_result(frames: dict[str, Path]) -> None:
    res = starid.identify_many([frames["png"], frames["trunc"], frames["jpg"]], fov_deg=FOV)
    assert [r.status for r in res] == ["identified", "invalid_input", "identified"]
    assert res[1].message is not None and "trunc.fits" in res[1].message


def test_a_decompression_bomb_is_a_typed_error(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.png"
    Image.new("1", (14_000, 14_000)).save(bomb)  # 24 kB on disk, 196 million pixels
    assert bomb.stat().st_size < 100_000
    with pytest.raises(starid.InvalidInputError, match="bomb.png"):
        starid.read_image(bomb)
    assert starid.identify_many([bomb], fov_deg=FOV)[0].status == "invalid_input"


def test_the_pixel_limit_is_checked_before_decoding(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import starid._read

    p = tmp_path / "big.png"
    Image.new("L", (200, 100)).save(p)
    monkeypatch.setattr(starid._read, "MAX_IMAGE_PIXELS", 10_000)
    with pytest.raises(starid.InvalidInputError, match="200 x 100 pixels"):
        starid.read_image(p)


@pytest.mark.parametrize("reader", [starid.read_image, starid.read_star_list, starid.Catalog.from_csv])
def test_a_device_is_refused_before_it_is_read(reader: object) -> None:
    if not os.path.exists("/dev/zero"):
        pytest.fail("/dev/zero is missing")
    with pytest.raises(ValueError, match="not a regular file"):
        reader("/dev/zero")  # type: ignore[operator]


def test_the_cli_reports_every_file_when_one_is_bad(frames: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(frames["png"]), str(frames["trunc"]), str(frames["jpg"])]
    assert main(["identify", *files, "--fov-deg", str(FOV), "--json"]) == 2
    out = json.loads(capsys.readouterr().out)
    assert [r["status"] for r in out] == ["identified", "invalid_input", "identified"]


@pytest.mark.parametrize("option", ["--wcs", "--annotate"])
def test_an_output_over_the_input_image_is_refused(frames: dict[str, Path], tmp_path: Path, option: str) -> None:
    img = tmp_path / "img.png"
    img.write_bytes(frames["png"].read_bytes())
    before = img.read_bytes()
    assert main(["identify", str(img), "--fov-deg", str(FOV), option, str(img)]) == 2
    assert img.read_bytes() == before


def test_a_wcs_over_the_star_list_is_refused(frames: dict[str, Path], tmp_path: Path) -> None:
    csv = tmp_path / "frame.csv"
    csv.write_bytes(frames["csv"].read_bytes())
    before = csv.read_bytes()
    size = f"{SIZE[0]}x{SIZE[1]}"
    assert main(["identify", str(csv), "--fov-deg", str(FOV), "--size", size, "--wcs", str(csv)]) == 2
    assert csv.read_bytes() == before


def test_simulate_over_its_catalogue_is_refused(tmp_path: Path) -> None:
    cat = tmp_path / "mycat.csv"
    starid.Catalog.default().to_csv(cat)
    before = cat.read_bytes()
    assert main(["simulate", str(cat), "--catalog", str(cat)]) == 2
    assert cat.read_bytes() == before


def test_an_output_through_a_symlink_replaces_the_link_not_its_target(frames: dict[str, Path], tmp_path: Path) -> None:
    target = tmp_path / "precious.csv"
    target.write_text("keep me\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    assert main(["simulate", str(link)]) == 0
    assert target.read_text() == "keep me\n"
    assert not link.is_symlink() and link.read_text().startswith("label,x,y,mag")


def test_annotate_through_a_symlink_leaves_its_target(frames: dict[str, Path], tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "other.png"
    target.write_bytes(b"not touched")
    link = tmp_path / "link.png"
    link.symlink_to(target)
    assert main(["identify", str(frames["png"]), "--fov-deg", str(FOV), "--annotate", str(link)]) == 0
    assert target.read_bytes() == b"not touched"
    assert not link.is_symlink() and link.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {link.resolve()}" in capsys.readouterr().err


def test_a_catalogue_rewritten_with_its_size_and_time_restored_is_read_again(tmp_path: Path) -> None:
    cat = tmp_path / "cache.csv"
    cat.write_text("id,ra_deg,dec_deg,mag\n1,10.0,20.0,3.0\n2,11.0,21.0,4.0\n")
    st = cat.stat()
    first = starid._catalog.resolve_catalog(str(cat))
    cat.write_text("id,ra_deg,dec_deg,mag\n7,10.0,20.0,3.0\n8,11.0,21.0,4.0\n")  # same size
    os.utime(cat, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert cat.stat().st_size == st.st_size and cat.stat().st_mtime_ns == st.st_mtime_ns
    again = starid._catalog.resolve_catalog(str(cat))
    assert first.ids.tolist() == [1, 2] and again.ids.tolist() == [7, 8]


def _sequence_files(folder: Path, prefix: str, frames: int, seed: int) -> list[str]:
    """A simulated 10 Hz sequence (12°, 512 px) written as star lists PREFIX0.csv, PREFIX1.csv..."""
    files = []
    for k, fr in enumerate(starid.simulate_sequence(None, 12.0, (512, 512), frames=frames, frame_rate_hz=10.0, seed=seed)):
        p = folder / f"{prefix}{k}.csv"
        p.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in fr.xy))
        files.append(str(p))
    return files


def test_track_goes_on_past_a_bad_frame_and_names_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = _sequence_files(tmp_path, "f", frames=4, seed=3)
    (tmp_path / "f1.csv").write_text("x,y\n1e6,1e6\n1,2\n3,4\n5,6\n")  # a spot far off the sensor
    assert main(["track", *files, "--fov-deg", "12", "--size", "512x512", "--frame-rate-hz", "10", "--json"]) == 2
    captured = capsys.readouterr()
    lines = [json.loads(line) for line in captured.out.splitlines()]
    assert [Path(d["file"]).name for d in lines] == ["f0.csv", "f1.csv", "f2.csv", "f3.csv"]
    assert lines[1]["status"] == "invalid_input" and lines[3]["ok"]
    assert "f1.csv" in captured.err


def test_track_reports_a_time_that_is_not_a_number_and_goes_on(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = _sequence_files(tmp_path, "g", frames=3, seed=4)
    assert main(["track", *files, "--fov-deg", "12", "--size", "512x512", "--times", "0,nan,0.2", "--json"]) == 2
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [d["status"] for d in lines][1] == "invalid_input" and len(lines) == 3


def test_track_takes_images(frames: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["track", str(frames["png"]), str(frames["png"]), "--fov-deg", str(FOV), "--size", "640x480", "--frame-rate-hz", "1", "--json"])
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert code == 0 and [d["ok"] for d in lines] == [True, True]


@pytest.mark.parametrize(
    "call",
    [
        pytest.param(lambda xy: starid.identify(xy, fov_deg=True, image_size=(512, 512)), id="fov_deg=True"),
        pytest.param(lambda xy: starid.identify(xy, fov_deg="12", image_size=(512, 512)), id="fov_deg='12'"),
        pytest.param(lambda xy: starid.identify(xy, fov_deg=12.0, image_size=(True, 512)), id="image_size bool"),
        pytest.param(lambda xy: starid.identify(xy, image_size=(512, 512), fov_range_deg=(False, 20)), id="range bool"),
        pytest.param(lambda xy: starid.identify_many("frame.csv", fov_deg=12.0, image_size=(512, 512)), id="str frames"),
        pytest.param(lambda xy: starid.identify_many({0: xy}, fov_deg=12.0, image_size=(512, 512)), id="dict frames"),
        pytest.param(lambda xy: starid.extract_centroids(np.zeros((64, 64), np.float32), deblend="no"), id="deblend='no'"),
    ],
)
def test_arguments_of_the_wrong_type_are_refused(call: object) -> None:
    xy = starid.simulate(seed=2, noise_px=0.1).xy
    with pytest.raises(starid.InvalidInputError):
        call(xy)  # type: ignore[operator]


def test_numpy_scalars_are_numbers() -> None:
    f = starid.simulate(seed=2, noise_px=0.1)
    res = starid.identify(f.xy, fov_deg=np.float32(12.0), image_size=(np.int64(512), np.uint16(512)))
    assert res.ok


def test_centroids_of_pure_noise_at_a_low_threshold_stay_on_the_image() -> None:
    noise = np.random.default_rng(0).normal(1000, 20, (1200, 1600)).astype(np.float32)
    res = starid.identify_image(noise, None, None, extract=dict(threshold_sigma=1.5, max_spots=10**6))
    xy = res.centroids.xy
    assert len(xy) > 1000
    assert ((xy >= 0) & (xy <= [1600, 1200])).all()


def test_a_trail_far_off_the_sensor_costs_no_more_than_one_across_it() -> None:
    import time

    t0 = time.perf_counter()
    img, _ = starid.simulate_image(None, 12.0, (320, 240), seed=1, trail=(-1e300, 0.0, 1e300, 1.0, 100.0))
    assert time.perf_counter() - t0 < 5.0 and img.shape == (240, 320)
    with pytest.raises(starid.InvalidInputError, match="trail"):
        starid.simulate_image(None, 12.0, (320, 240), seed=1, trail=(0.0, 0.0, float("nan"), 10.0, 100.0))
