"""Results in the ecosystem's forms: the per-spot table (numpy, pandas, astropy), the WCS of any
result, the CLI's --corr and --json, and the round trip through a WCS header with astropy."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import starid
from starid.cli import main

FOV, SIZE = 12.0, (640, 480)


@pytest.fixture(scope="module")
def frame() -> starid.Frame:
    return starid.simulate(None, FOV, SIZE, seed=12, noise_px=0.1, false_stars=2, mag_noise=0.05)


@pytest.fixture(scope="module")
def result(frame: starid.Frame) -> starid.Identification:
    res = starid.identify(frame.xy, fov_deg=FOV, image_size=SIZE, magnitudes=frame.magnitudes)
    assert res.ok
    return res


def test_the_table_has_a_row_per_spot_with_its_star(frame: starid.Frame, result: starid.Identification) -> None:
    t = result.table()
    assert t.dtype.names == ("x", "y", "catalog_id", "ra_deg", "dec_deg", "catalog_mag", "mag", "residual_arcsec")
    assert len(t) == len(frame.xy)
    assert np.array_equal(t["x"], frame.xy[:, 0]) and np.array_equal(t["y"], frame.xy[:, 1])
    assert np.array_equal(t["catalog_id"], result.ids)
    assert np.array_equal(t["mag"], frame.magnitudes)
    named = t["catalog_id"] >= 0
    cat = starid.Catalog.default()
    rows = {int(i): k for k, i in enumerate(cat.ids)}
    for r in t[named]:
        k = rows[int(r["catalog_id"])]
        assert r["ra_deg"] == pytest.approx(cat.ra_deg[k], abs=1e-9)
        assert r["dec_deg"] == pytest.approx(cat.dec_deg[k], abs=1e-9)
        assert r["catalog_mag"] == pytest.approx(cat.mag[k], abs=1e-9)
    assert np.isnan(t["ra_deg"][~named]).all() and (t["catalog_id"][~named] == -1).all()


def test_the_table_survives_pickling_and_converts(result: starid.Identification) -> None:
    back = pickle.loads(pickle.dumps(result))
    t, u = result.table(), back.table()
    for name in t.dtype.names:
        assert np.array_equal(t[name], u[name], equal_nan=True), name
    assert back.image_size == SIZE and back.principal_point == (SIZE[0] / 2, SIZE[1] / 2)
    df = result.to_pandas()
    assert list(df.columns) == list(t.dtype.names) and len(df) == len(t)
    at = result.to_astropy()
    assert str(at["ra_deg"].unit) == "deg" and at["coord"].frame.name == "icrs"


def test_wcs_positions_land_on_the_catalogue_within_the_residuals(result: starid.Identification) -> None:
    from astropy.coordinates import SkyCoord
    import astropy.units as u

    w = result.wcs()
    t = result.table()
    named = t[t["catalog_id"] >= 0]
    # astropy counts pixels from 0 at the first pixel's centre: starid's x - 0.5.
    ra, dec = w.all_pix2world(named["x"] - 0.5, named["y"] - 0.5, 0)
    sep = SkyCoord(ra * u.deg, dec * u.deg).separation(SkyCoord(named["ra_deg"] * u.deg, named["dec_deg"] * u.deg))
    assert np.allclose(sep.arcsec, named["residual_arcsec"], atol=0.05)


def test_an_image_result_keeps_its_spots_and_wcs(tmp_path: Path) -> None:
    img, _ = starid.simulate_image(None, FOV, SIZE, seed=4)
    png = tmp_path / "frame.png"
    Image.fromarray(np.clip(img, 0, 65535).astype(np.uint16)).save(png)
    res = starid.identify(png, fov_deg=FOV)
    assert res.ok and res.image_size == SIZE
    spots = starid.extract_centroids(png)
    assert np.array_equal(res.xy, spots.xy) and np.array_equal(res.magnitudes, spots.magnitudes)
    assert res.wcs_header()["CTYPE1"].startswith("RA---TAN")


# A header-only WCS file (as solve-field writes) has NAXIS = 0, which astropy remarks on.
@pytest.mark.filterwarnings("ignore::astropy.wcs.FITSFixedWarning")
def test_cli_corr_and_json_carry_positions(frame: starid.Frame, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    from astropy.io import fits
    from astropy.table import Table
    from astropy.wcs import WCS

    csv = tmp_path / "frame.csv"
    csv.write_text("label,x,y,mag\n" + "".join(f"s{i},{float(x)!r},{float(y)!r},{float(m)!r}\n" for i, ((x, y), m) in enumerate(zip(frame.xy, frame.magnitudes))))
    size = f"{SIZE[0]}x{SIZE[1]}"
    corr, wcs = tmp_path / "frame.corr", tmp_path / "frame.wcs"
    assert main(["identify", str(csv), "--fov-deg", str(FOV), "--size", size, "--corr", str(corr), "--wcs", str(wcs)]) == 0
    err = capsys.readouterr().err
    assert f"wrote {corr.resolve()}" in err and f"wrote {wcs.resolve()}" in err
    t = Table.read(corr)
    assert len(t) > 5 and (t["catalog_id"] >= 0).all()
    w = WCS(fits.getheader(wcs))
    ra, dec = w.all_pix2world(np.asarray(t["x"]) + 0.5, np.asarray(t["y"]) + 0.5, 1)  # FITS: 1-based centres
    from astropy.coordinates import SkyCoord
    import astropy.units as u

    sep = SkyCoord(ra * u.deg, dec * u.deg).separation(SkyCoord(np.asarray(t["ra_deg"]) * u.deg, np.asarray(t["dec_deg"]) * u.deg))
    assert np.allclose(sep.arcsec, np.asarray(t["residual_arcsec"]), atol=0.05)
    as_csv = tmp_path / "frame-corr.csv"
    assert main(["identify", str(csv), "--fov-deg", str(FOV), "--size", size, "--corr", str(as_csv)]) == 0
    assert as_csv.read_text().splitlines()[0] == "x,y,catalog_id,ra_deg,dec_deg,catalog_mag,mag,residual_arcsec"
    capsys.readouterr()
    assert main(["identify", str(csv), "--fov-deg", str(FOV), "--size", size, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["x"] == pytest.approx(frame.xy[:, 0].tolist()) and d["y"] == pytest.approx(frame.xy[:, 1].tolist())


def test_centroids_from_sep_or_photutils_go_in_with_their_origin(frame: starid.Frame, result: starid.Identification) -> None:
    theirs = frame.xy - 0.5  # sep, photutils and astropy: the first pixel's centre at 0
    res = starid.identify(theirs, fov_deg=FOV, image_size=SIZE, magnitudes=frame.magnitudes, pixel_origin="center")
    assert np.array_equal(res.ids, result.ids) and res.ra_deg == pytest.approx(result.ra_deg, abs=1e-12)
    assert np.allclose(res.xy, frame.xy)
    batch = starid.identify_many([theirs], fov_deg=FOV, image_size=SIZE, magnitudes=[frame.magnitudes], pixel_origin="center")
    assert np.array_equal(batch[0].ids, result.ids)
    with pytest.raises(starid.InvalidInputError, match="pixel_origin"):
        starid.identify(theirs, fov_deg=FOV, image_size=SIZE, pixel_origin="centre")


@pytest.mark.parametrize("name", ["sim.png", "sim.tif", "sim.fits"])
def test_simulate_writes_a_16_bit_image_that_solves(tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / name
    assert main(["simulate", "--image", str(out), "--fov-deg", str(FOV), "--size", "640x480", "--seed", "5"]) == 0
    truth = json.loads(capsys.readouterr().out)
    img = starid.read_image(out)
    assert img.dtype == np.uint16 and img.shape == (480, 640)
    res = starid.identify(out, fov_deg=FOV)
    assert res.ok and res.ra_deg == pytest.approx(truth["ra_deg"], abs=0.01)


def test_version_and_readable_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    import inspect

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and starid.__version__ in capsys.readouterr().out
    assert repr(inspect.signature(starid.identify).parameters["mag_offset"].default) == "0.0"
    try:
        starid.identify(np.zeros((5, 2)), fov_deg=FOV, image_size=SIZE, min_matches=2)
    except starid.InvalidInputError as err:
        assert err.__context__ is None or err.__suppress_context__
    else:
        pytest.fail("min_matches=2 was accepted")


def test_image_times_are_split_into_read_extract_identify(tmp_path: Path, result: starid.Identification,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    import math

    out = tmp_path / "frame.png"
    assert main(["simulate", "--image", str(out), "--size", "640x480", "--seed", "6"]) == 0
    capsys.readouterr()
    res = starid.identify(out, fov_deg=FOV)
    assert res.read_s > 0 and res.extract_s > 0 and res.time_s > 0
    batch = starid.identify_many([out, out], fov_deg=FOV)
    assert all(r.read_s > 0 and r.extract_s > 0 for r in batch)
    assert math.isnan(result.read_s) and math.isnan(result.extract_s)  # centroids given
    back = pickle.loads(pickle.dumps(res))
    assert back.read_s == res.read_s and back.extract_s == res.extract_s
    assert main(["identify", str(out), "--fov-deg", str(FOV)]) == 0
    line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("time:")][0]
    assert "read" in line and "extract" in line and "identify" in line
