"""Camera calibration through Python: frames to a camera, the camera to a file and a WCS, and back
into identification and the simulator."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
from astropy.wcs import WCS

import starid
from starid import cli

SIZE = (1280, 1024)


def _lens(fov: float = 40.0) -> starid.Camera:
    return starid.Camera(SIZE, fov, principal_point=(652.0, 500.0), k1=-0.2, k2=0.03, p1=6e-4, p2=-4e-4)


@pytest.fixture(scope="module")
def wide() -> tuple[starid.Camera, list[starid.Frame], object]:
    truth = _lens()
    frames = [starid.simulate(camera=truth, noise_px=0.2, mag_noise=0.1, seed=100 + s) for s in range(10)]
    cal = starid.calibrate([f.xy for f in frames], camera=starid.Camera(SIZE, 40.0), magnitudes=[f.magnitudes for f in frames])
    return truth, frames, cal


def test_a_wide_lens_is_recovered_from_its_own_frames(wide):
    truth, frames, cal = wide
    cam, sig = cal.camera, cal.sigmas
    assert abs(cam.focal_length_px / truth.focal_length_px - 1) < 2e-4
    assert abs(cam.focal_length_px - truth.focal_length_px) < 5 * sig["focal_length_px"]
    for name, want in (("cx", truth.principal_point[0]), ("cy", truth.principal_point[1])):
        got = cam.principal_point[0 if name == "cx" else 1]
        assert abs(got - want) < 5 * sig[name], (name, got, want, sig[name])
    assert abs(cam.k1 - truth.k1) < 5 * sig["k1"]
    assert 0.18 < cal.rms_px < 0.21 < 1.0 < cal.rms_before_px
    assert cal.covariance.shape == (len(cal.parameters),) * 2
    np.testing.assert_allclose(np.sqrt(np.diag(cal.covariance)), [sig[p] for p in cal.parameters])
    before, after, total = cal.identified
    assert total == 10 and before <= after == 10
    assert cal.n_frames == 10 and cal.quaternions.shape == (10, 4) and cal.rotation_matrices.shape == (10, 3, 3)
    assert len(cal.residuals_px) == len(cal.inliers) == 10
    assert cal.n_clipped == len(cal.clipped) and cal.time_s > 0


def test_the_calibrated_camera_identifies_with_no_wrong_id(wide):
    truth, frames, cal = wide
    for f in frames:
        res = starid.identify(f.xy, camera=cal.camera, magnitudes=f.magnitudes)
        assert res.ok
        named = res.ids >= 0
        assert (res.ids[named] == f.true_ids[named]).all()
        assert named.sum() >= 0.9 * (f.true_ids >= 0).sum()
        assert res.camera.k2 == cal.camera.k2 and res.camera.p1 == cal.camera.p1


def test_identifications_calibrate_too(wide):
    truth, frames, _ = wide
    results = starid.identify_many([f.xy for f in frames], camera=_lens(), magnitudes=[f.magnitudes for f in frames])
    cal = starid.calibrate(results, camera=starid.Camera(SIZE, 40.0))
    assert cal.identified is None and cal.n_frames == 10
    assert abs(cal.camera.k1 - truth.k1) < 5 * cal.sigmas["k1"]
    with pytest.raises(starid.InvalidInputError, match="not both"):
        starid.calibrate([results[0], frames[0].xy], camera=_lens())
    with pytest.raises(starid.InvalidInputError, match="already identified"):
        starid.calibrate(results, magnitudes=[None] * 10)


def test_the_camera_round_trips_through_its_file_and_pickle(wide, tmp_path):
    _, _, cal = wide
    path = tmp_path / "camera.json"
    cal.save(path)
    doc = json.loads(path.read_text())
    assert doc["format"] == "starid-camera" and doc["calibration"]["parameters"] == cal.parameters
    assert starid.load_camera(path) == cal.camera
    assert pickle.loads(pickle.dumps(cal.camera)) == cal.camera
    cal.camera.save(tmp_path / "bare.json")
    assert starid.load_camera(tmp_path / "bare.json") == cal.camera
    (tmp_path / "bad.json").write_text('{"format": "other"}')
    with pytest.raises(starid.InvalidInputError, match="not a starid camera file"):
        starid.load_camera(tmp_path / "bad.json")
    (tmp_path / "broken.json").write_text('{"format": "starid-camera", "camera": {}}')
    with pytest.raises(starid.InvalidInputError, match="not a readable"):
        starid.load_camera(tmp_path / "broken.json")


@pytest.mark.parametrize("mirrored", [False, True])
def test_the_sip_header_carries_the_full_model(mirrored):
    truth = _lens(50.0)
    f = starid.simulate(camera=truth, seed=5, mirrored=mirrored, mag_noise=0.1)
    res = starid.identify(f.xy, camera=truth, magnitudes=f.magnitudes, focal_check=False)
    assert res.ok and res.mirrored == mirrored
    header = res.wcs_header()
    assert header["CTYPE1"] == "RA---TAN-SIP" and header["A_ORDER"] in (5, 7, 9)
    w = WCS(header)
    named = res.ids >= 0
    ra, dec, _ = res._star_columns()
    sky = w.all_pix2world(f.xy[named] + 0.5, 1)  # FITS pixel centres are at starid's + 0.5, 1-based
    err = np.hypot((sky[:, 0] - ra[named]) * np.cos(np.radians(dec[named])), sky[:, 1] - dec[named])
    pixel_deg = np.degrees(1 / truth.focal_length_px)
    assert err.max() < 0.02 * pixel_deg
    back = w.all_world2pix(np.column_stack([ra[named], dec[named]]), 1) - 0.5
    assert np.abs(back - f.xy[named]).max() < 0.02


def test_the_simulator_takes_the_camera_whole():
    truth = _lens()
    f = starid.simulate(camera=truth, seed=2)
    assert f.image_size == truth.image_size
    with pytest.raises(starid.InvalidInputError, match="radial_k1"):
        starid.simulate(camera=truth, radial_k1=0.1)
    with pytest.raises(starid.InvalidInputError):
        starid.Camera(SIZE, 40.0, p1=2.0)


def test_calibrate_refuses_what_it_cannot_use():
    with pytest.raises(starid.InvalidInputError, match="at least one"):
        starid.calibrate([])
    with pytest.raises(starid.InvalidInputError, match="need the camera"):
        starid.calibrate([np.zeros((5, 2))])
    with pytest.raises(starid.InvalidInputError, match="no frame was identified"):
        starid.calibrate([np.random.default_rng(1).uniform(0, 1000, (30, 2))], camera=starid.Camera(SIZE, 40.0))


def test_the_command_calibrates_and_identifies_with_the_file(tmp_path, capsys):
    truth = starid.Camera((1024, 768), 30.0, principal_point=(520.0, 380.0), k1=-0.1)
    files = []
    for s in range(6):
        f = starid.simulate(camera=truth, noise_px=0.2, mag_noise=0.1, seed=s)
        path = tmp_path / f"f{s}.csv"
        path.write_text("label,x,y,mag\n" + "".join(f"s{i},{x},{y},{m}\n" for i, ((x, y), m) in enumerate(zip(f.xy, f.magnitudes))))
        files.append(str(path))
    out = tmp_path / "camera.json"
    assert cli.main(["calibrate", *files, "--fov-deg", "30", "--size", "1024x768", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "6/6 with the calibrated one" in text and "RMS residual" in text
    cam = starid.load_camera(out)
    assert abs(cam.k1 - truth.k1) < 0.01
    assert cli.main(["identify", files[0], "--camera", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ok"]
    assert cli.main(["calibrate", *files, "--fov-deg", "30", "--size", "1024x768", "-o", files[0]]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert cli.main(["identify", files[0], "--camera", str(out), "--fov-deg", "30"]) == 2


def test_a_tracker_follows_the_sky_through_the_calibrated_camera(wide):
    truth, _, cal = wide
    tracker = starid.Tracker(camera=cal.camera)
    for k in range(6):
        f = starid.simulate(camera=truth, attitude_deg=(120.0 + 0.05 * k, 25.0, 40.0), noise_px=0.2, mag_noise=0.1, seed=k)
        step = tracker.update(f.xy, 0.1 * k, magnitudes=f.magnitudes)
        res = step.identification
        assert res.ok
        named = res.ids >= 0
        assert (res.ids[named] == f.true_ids[named]).all() and named.sum() >= 0.9 * (f.true_ids >= 0).sum()
