"""starid.pointing and identification with an unknown field of view."""

from __future__ import annotations

import math
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import starid
import starid.pointing as sp
import starid._unknown_field as unknown_field
from starid._unknown_field import stages
from starid.cli import main

ARCSEC = math.radians(1 / 3600)
F12 = starid.Camera((512, 512), 12.0).focal_length_px


def _unit(ra: np.ndarray, dec: np.ndarray) -> np.ndarray:
    ra, dec = np.radians(ra), np.radians(dec)
    return np.stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)], axis=-1)


def _angle(ra1: float, dec1: float, ra2: float, dec2: float) -> float:
    a, b = _unit(np.array(ra1), np.array(dec1)), _unit(np.array(ra2), np.array(dec2))
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))  # accurate at tiny angles


def _sky(offsets: np.ndarray, f: float, frame: starid.Frame) -> np.ndarray:
    """RA/Dec of the points imaged at `offsets` (from the centre) by the camera of `frame`."""
    r = frame.rotation_matrix
    rays = np.column_stack([offsets, np.full(len(offsets), f)])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    v = rays @ r  # R^T applied to each ray
    return np.column_stack([np.degrees(np.arctan2(v[:, 1], v[:, 0])) % 360, np.degrees(np.arcsin(v[:, 2]))])


@pytest.fixture(scope="module")
def frame() -> starid.Frame:
    return starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=21)


def test_exact_distances_give_the_boresight(frame: starid.Frame) -> None:
    off = np.array([[230.0, 20.0], [-100.0, 200.0], [-120.0, -190.0]])
    radec = _sky(off, F12, frame)
    a = np.hypot(off[:, 0], off[:, 1])
    sols = sp.boresight_from_distances(radec, a, focal_px=F12)
    best = sols[0]
    assert best.best and not best.ambiguous and not best.degenerate
    assert _angle(best.ra_deg, best.dec_deg, frame.ra_deg, frame.dec_deg) < 0.01 * ARCSEC
    unknown = sp.boresight_from_distances(radec, a)
    hits = [s for s in unknown if _angle(s.ra_deg, s.dec_deg, frame.ra_deg, frame.dec_deg) < 0.01 * ARCSEC]
    assert hits and abs(hits[0].focal_px / F12 - 1) < 1e-9
    # A plausible focal range leaves the true solution alone.
    ranged = sp.boresight_from_distances(radec, a, focal_range_px=(F12 * 0.5, F12 * 1.5))
    assert len(ranged) == 1 and not ranged[0].ambiguous
    assert abs(ranged[0].focal_px / F12 - 1) < 1e-9


def test_geometry_flags(frame: starid.Frame) -> None:
    collinear = np.array([[-200.0, 60.0], [10.0, 60.0], [190.0, 60.0]])
    sols = sp.boresight_from_distances(_sky(collinear, F12, frame), np.hypot(*collinear.T), focal_px=F12)
    assert len(sols) >= 2 and sols[0].ambiguous and sols[1].ambiguous
    through = np.array([[-200.0, 0.0], [30.0, 0.0], [180.0, 0.0]])
    sols = sp.boresight_from_distances(_sky(through, F12, frame), np.abs(through[:, 0]), focal_px=F12)
    assert sols[0].degenerate and sols[0].boresight_sigma_arcsec(0.1) == math.inf
    assert sp.predicted_covariance(through + 256, (512, 512), focal_px=F12)["covariance"] is None


def test_precision_and_star_choice() -> None:
    spread = np.array([[486.0, 276.0], [141.0, 455.0], [136.0, 61.0]])
    clustered = np.array([[356.0, 356.0], [386.0, 361.0], [366.0, 384.0]])
    collinear = np.array([[60.0, 300.0], [250.0, 300.0], [470.0, 300.0]])
    s = lambda xy, ff: sp.predicted_covariance(xy, (512, 512), fov_deg=12, fit_focal=ff)["boresight_sigma_arcsec"]  # noqa: E731
    for fit_focal in (False, True):
        assert s(spread, fit_focal) < s(clustered, fit_focal)
        assert s(spread, fit_focal) < s(collinear, fit_focal)
    frame_xy = np.vstack([clustered, spread, [[300.0, 300.0]]])
    idx, sigma = sp.choose_stars(frame_xy, (512, 512), fov_deg=12)
    assert idx == [3, 4, 5] and sigma == pytest.approx(s(spread, False))
    idx4, sigma4 = sp.choose_stars(frame_xy, (512, 512), 4, fov_deg=12)
    assert len(idx4) == 4 and sigma4 < sigma


@pytest.mark.parametrize("fit_focal", [False, True])
def test_monte_carlo_matches_prediction(fit_focal: bool) -> None:
    """0.1 px on a 12 deg / 512 px frame: scatter within 10 % of the predicted covariance."""
    mc = sp.monte_carlo([[486, 276], [141, 455], [136, 61]], (512, 512), fov_deg=12, sigma_px=0.1,
                        fit_focal=fit_focal, trials=2000, seed=3)
    assert mc["outliers"] == 0
    assert abs(mc["ratio"] - 1) < 0.1


@pytest.mark.parametrize("wrong", [0.6, 1.4])
def test_fit_pointing_converges_from_a_40_percent_fov_error(bundled: starid.Catalog, wrong: float) -> None:
    frame = starid.simulate(bundled, 12.0, (512, 512), seed=9)
    real = frame.true_ids >= 0
    rows = [int(np.flatnonzero(bundled.ids == i)[0]) for i in frame.true_ids[real]]
    radec = np.column_stack([bundled.ra_deg[rows], bundled.dec_deg[rows]])
    fit = sp.fit_pointing(radec, frame.xy[real], (512, 512), fov_deg=12.0 * wrong)
    assert fit.converged
    assert abs(fit.focal_px / F12 - 1) < 1e-9
    assert _angle(fit.ra_deg, fit.dec_deg, frame.ra_deg, frame.dec_deg) < 1e-6 * ARCSEC
    assert fit.parameters == ["rot_x", "rot_y", "rot_z", "focal_px"]


def test_refine_fits_principal_point_and_distortion(bundled: starid.Catalog) -> None:
    """A frame made with a shifted principal point and barrel distortion is refined back."""
    frame = starid.simulate(bundled, 14.0, (1024, 1024), seed=17, noise_px=0.0)
    f = starid.Camera((1024, 1024), 14.0).focal_length_px
    cx, cy, k1 = 518.0, 509.0, -0.05
    u = (frame.xy - 512.0) / f
    g = 1 + k1 * (u**2).sum(axis=1, keepdims=True)
    xy = np.array([cx, cy]) + f * u * g
    res = starid.identify(frame.xy, bundled, fov_deg=14.0, image_size=(1024, 1024))
    assert res.ok
    fit = sp.refine(res, xy, bundled, (1024, 1024), fit_principal_point=True, fit_k1=True)
    assert fit.converged
    assert fit.principal_point_px == pytest.approx((cx, cy), abs=1e-6)
    assert fit.k1 == pytest.approx(k1, abs=1e-8)
    assert fit.focal_px == pytest.approx(f, rel=1e-9)
    assert fit.covariance is not None and fit.covariance.shape == (7, 7)


def test_unknown_fov_identification(bundled: starid.Catalog) -> None:
    rng = np.random.default_rng(4)
    wrong = tried = ok = 0
    for seed in range(20):
        fov = float(rng.uniform(8, 25))
        frame = starid.simulate(bundled, fov, (1024, 1024), seed=seed, noise_px=0.2, mirrored=seed % 2 == 1)
        if frame.n_real < 4:
            continue
        tried += 1
        res = starid.identify(frame.xy, bundled, image_size=(1024, 1024), fov_range_deg=(8.0, 25.0))
        if not res.ok:
            continue
        ok += 1
        wrong += int(((res.ids >= 0) & (res.ids != frame.true_ids)).sum())
        assert res.mirrored == frame.mirrored
        assert abs(res.focal_px / starid.Camera((1024, 1024), fov).focal_length_px - 1) < 1e-3
        assert res.focal_sigma_px > 0
    assert wrong == 0
    assert ok >= tried - 1


def _truth_frame(fov: float, seed: int) -> starid.Frame:
    """A 1024x768 frame of stars to a depth that leaves a few dozen in the field."""
    deep = starid.Catalog.deep(9.0)
    limit = min(9.0, 6.0 + 12.0 / fov)
    return starid.simulate(deep, fov, (1024, 768), seed=seed, mag_limit=limit, noise_px=0.3, mag_noise=0.2)


@pytest.mark.parametrize("fov", [4.5, 6.0, 33.0, 45.0])
def test_a_field_outside_the_default_range_is_found_without_being_given(fov: float) -> None:
    # Narrow and wide fields, no field of view and no catalogue given, magnitudes of an unknown
    # zero point: the bands beyond 8-25 degrees find them, each with its own catalogue depth.
    f = _truth_frame(fov, seed=int(fov * 10))
    res = starid.identify(f.xy, image_size=(1024, 768), magnitudes=f.magnitudes + 3.0, mag_offset=None)
    assert res.ok and abs(res.fov_deg / fov - 1) < 2e-3
    named = res.ids >= 0
    assert np.array_equal(res.ids[named], f.true_ids[named]) and named.sum() >= 10
    assert res.false_match_probability <= 1e-3 and res.time_s > 0


@settings(max_examples=8, deadline=None)
@given(st.floats(4.0, 50.0), st.integers(0, 2**31))
# A frame of no more spots than a stage's brightest few: its result once came back in the
# brightness order, each id on another spot.
@example(7.5, 0)
def test_an_unknown_field_is_never_named_wrong(fov: float, seed: int) -> None:
    f = _truth_frame(fov, seed)
    res = starid.identify(f.xy, image_size=(1024, 768), magnitudes=f.magnitudes + 3.0, mag_offset=None)
    named = res.ids >= 0
    assert np.array_equal(res.ids[named], f.true_ids[named])


def test_the_stages_of_an_unknown_field() -> None:
    size = (1024.0, 768.0)
    plan = stages(None, None, size)
    assert [(lo, hi, spots) for lo, hi, _, spots, _ in plan] == [
        (8.0, 25.0, 10), (4.0, 8.0, 10), (4.0, 8.0, 10), (4.0, 8.0, 6), (25.0, 60.0, 10), (8.0, 25.0, None)
    ]
    assert [load().name.split()[1] for _, _, load, _, _ in plan] == ["Hp<=6.5", "Hp<=6.5", "Hp<=7", "Hp<=8", "Hp<=5.5", "Hp<=6.5"]
    # The first stage's band is the full stage's: half the budget, the full stage finding the rest.
    assert [pairs for *_, pairs in plan] == [50_000, 100_000, 100_000, 100_000, 100_000, None]
    assert [pairs for *_, pairs in stages(None, None, size, full=False)] == [100_000] * 5
    # A range given narrows the bands; the last stage searches all of it with every spot.
    narrowed = [(lo, hi) for lo, hi, *_ in stages(None, (5.0, 10.0), size)]
    assert narrowed == [(8.0, 10.0), (5.0, 8.0), (5.0, 8.0), (5.0, 8.0), (5.0, 10.0)]
    assert [(lo, hi) for lo, hi, *_ in stages(None, (5.0, 10.0), size, full=False)] == narrowed[:-1]
    # A catalogue given is searched in every band, once per band.
    own = starid.Catalog.default()
    plan = stages(own, None, size)
    assert all(load() is own for _, _, load, _, _ in plan) and len(plan) == 4


def test_the_full_stage_beside_the_quick_ones_gives_what_they_give_in_turn(monkeypatch: pytest.MonkeyPatch) -> None:
    # One frame the quick stages identify, one only the full stage does (ten false spots,
    # their magnitudes among the stars'), one nothing does: the full stage begun on a thread
    # of its own as soon as the first stage fails gives each the result of the stages in turn.
    deep = starid.Catalog.deep(9.0)
    frames = [
        starid.simulate(deep, 15.0, (1024, 768), seed=seed, mag_limit=6.8, noise_px=0.3, mag_noise=0.2, false_stars=fs)
        for seed, fs in [(1, 0), (5, 10)]
    ]
    noise = np.random.default_rng(3).uniform(0, 1024, (30, 2)) * [1.0, 0.75]
    spots = [(f.xy, f.magnitudes + 3.0) for f in frames] + [(noise, np.linspace(2.0, 7.0, 30))]
    started = []
    start = unknown_field._starid.identify_unknown_fov_start

    def spy(*args: object) -> object:
        started.append(args)
        return start(*args)

    monkeypatch.setattr(unknown_field._starid, "identify_unknown_fov_start", spy)
    runs = {}
    for cores in (1, 2):
        monkeypatch.setattr(unknown_field, "_cores", lambda threads, n=cores: n)
        runs[cores] = [starid.identify(xy, image_size=(1024, 768), magnitudes=m, mag_offset=None) for xy, m in spots]
    assert len(started) == 2  # (the first frame's first stage finds it: nothing is begun for it)
    assert [r.status for r in runs[2]] == [r.status for r in runs[1]] == ["identified", "identified", "search_limit"]
    for one, two, f in zip(runs[1], runs[2], frames):
        assert np.array_equal(one.ids, two.ids) and one.fov_deg == two.fov_deg
        named = two.ids >= 0
        assert np.array_equal(two.ids[named], f.true_ids[named])


def test_a_batch_of_an_unknown_field_searches_its_frames_left_at_the_field_learned() -> None:
    # Twelve frames of one camera, ten false spots each: one by one, the stages miss seeds 2,
    # 7 and 11; as a batch, the field the others agree on finds them too, named right. Sets of
    # random points in the batch, searched again at that field, stay unnamed.
    deep = starid.Catalog.deep(9.0)
    size = (1024, 768)
    frames = [
        starid.simulate(deep, 12.0, size, seed=s, mag_limit=7.0, noise_px=0.3, mag_noise=0.2, false_stars=10)
        for s in range(12)
    ]
    kw = dict(image_size=size, mag_offset=None)
    assert not any(starid.identify(frames[s].xy, magnitudes=frames[s].magnitudes + 3.0, **kw).ok for s in (2, 7, 11))
    rng = np.random.default_rng(8)
    noise = [(rng.uniform(0, 1, (n, 2)) * size, rng.uniform(3.0, 9.0, n)) for n in (8, 15, 25, 40)]
    batch = starid.identify_many(
        [f.xy for f in frames] + [xy for xy, _ in noise],
        magnitudes=[f.magnitudes + 3.0 for f in frames] + [m for _, m in noise],
        **kw,
    )
    assert not any(r.ok for r in batch[12:])
    batch = batch[:12]
    assert all(r.ok for r in batch)
    for r, f in zip(batch, frames):
        named = r.ids >= 0
        assert np.array_equal(r.ids[named], f.true_ids[named]) and abs(r.fov_deg / 12.0 - 1) < 2e-3
        assert r.false_match_probability <= 1e-3
    assert unknown_field.learned_field(batch[:3]) == pytest.approx(12.0, rel=2e-3)
    # Too few frames identified, or frames of several lenses: nothing is learned.
    assert unknown_field.learned_field(batch[:2]) is None
    lenses = [SimpleNamespace(ok=True, fov_deg=v) for v in (12.0, 12.01, 15.0, 15.02, 20.0)]
    assert unknown_field.learned_field(lenses) is None
    assert unknown_field.learned_field(lenses[:2] + [SimpleNamespace(ok=True, fov_deg=12.05)]) == 12.01


def test_a_search_begun_beside_stops_when_told() -> None:
    spots = np.random.default_rng(5).uniform(0, 512, (20_000, 2))
    cat = starid.Catalog.default()
    search = starid._starid.identify_unknown_fov_start(cat._native, spots, None, 512.0, 512.0, 8.0, 25.0, starid.IdentifyConfig())
    t0 = time.perf_counter()
    search.cancel()
    res = search.result()
    assert time.perf_counter() - t0 < 0.5 and not res.ok and "cancelled" in repr(search)
    assert search.result().status == res.status
    # Two threads waiting on one search: each gets its result once it is stopped.
    search = starid._starid.identify_unknown_fov_start(cat._native, spots, None, 512.0, 512.0, 8.0, 25.0, starid.IdentifyConfig())
    got: list[str] = []
    waiters = [threading.Thread(target=lambda: got.append(search.result().status)) for _ in range(2)]
    for w in waiters:
        w.start()
    time.sleep(0.05)
    search.cancel()
    for w in waiters:
        w.join(timeout=5.0)
    assert len(got) == 2 and got[0] == got[1] and not any(w.is_alive() for w in waiters)


@given(st.floats(0.0, 360.0), st.floats(-80.0, 80.0), st.floats(0.0, 360.0))
def test_exact_three_star_problem_property(ra: float, dec: float, roll: float) -> None:
    frame = starid.simulate(fov_deg=12.0, image_size=(512, 512), attitude_deg=(ra, dec, roll), seed=1)
    off = np.array([[220.0, 40.0], [-90.0, 210.0], [-140.0, -170.0]])
    sols = sp.boresight_from_distances(_sky(off, F12, frame), np.hypot(*off.T), focal_px=F12)
    assert _angle(sols[0].ra_deg, sols[0].dec_deg, ra, dec) < 0.01 * ARCSEC


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: sp.boresight_from_distances([[0, 0], [1, 1]], [1, 2], 100.0), "at least 3"),
        (lambda: sp.boresight_from_distances([[0, 0], [1, 1], [2, 0]], [1, 2], 100.0), "distances"),
        (lambda: sp.boresight_from_distances([[0, 0], [1, 1], [2, 0]], [1, float("nan"), 2], 100.0), "distance"),
        (lambda: sp.boresight_from_distances([[0, 0], [1, 1], [2, 0]], [1, 2, 3], -5.0), "focal"),
        (lambda: sp.boresight_from_distances([[0, 0], [0, 0], [2, 0]], [1, 2, 3], 100.0), "same direction"),
        (lambda: sp.boresight_from_distances([[0, 95], [1, 1], [2, 0]], [1, 2, 3], 100.0), "declination"),
        (lambda: sp.boresight_from_distances([[0, 0, 0]], [1], 100.0), "shape"),
        (lambda: sp.fit_pointing([[0, 0], [1, 1], [2, 0]], [[1, 1], [2, 2]], (512, 512), fov_deg=10), "image positions"),
        (lambda: sp.fit_pointing([[0, 0], [1, 1], [2, 0]], [[1, 1], [2, 2], [3, 9]], (512, 512)), "focal"),
        (lambda: sp.fit_pointing([[0, 0], [1, 1], [2, 0]], [[1, 1], [2, 2], [3, 9]], (512, 512), fit_focal=False), "given"),
        (lambda: sp.choose_stars([[1, 1], [2, 2], [3, 3]], (512, 512), 2, fov_deg=10), "3"),
        (lambda: sp.predicted_covariance([[1, 1], [2, 2], [3, 3]], (512, 512)), "focal_px or fov_deg"),
        (lambda: sp.monte_carlo([[1, 1], [2, 2], [3, 3]], (512, 512), fov_deg=10, trials=1), "trials"),
    ],
)
def test_bad_input(call, message: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=message):
        call()


def test_cli_boresight(capsys) -> None:  # type: ignore[no-untyped-def]
    stars = ["--star", "83", "-1", "67.23", "--star", "86.5", "2", "142.72", "--star", "80.5", "3", "166.21"]
    assert main(["boresight", *stars, "--fov-deg", "12", "--width", "512"]) == 0
    out = capsys.readouterr().out
    assert "ra 83.4999" in out and "dec +0.4999" in out and "[best]" in out
    assert main(["boresight", *stars, "--width", "512", "--fov-range-deg", "8", "20", "--json"]) == 0
    import json

    sols = json.loads(capsys.readouterr().out)
    assert len(sols) == 1 and abs(sols[0]["focal_px"] - F12) < 0.1
    assert main(["boresight", *stars[:8]]) == 2
    assert "at least 3" in capsys.readouterr().err


def test_cli_identify_with_unknown_fov(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    frame_file = tmp_path / "f.csv"
    assert main(["simulate", str(frame_file), "--fov-deg", "15", "--size", "1024x1024", "--seed", "3"]) == 0
    capsys.readouterr()
    assert main(["identify", str(frame_file), "--size", "1024x1024", "--fov-range-deg", "10", "20"]) == 0
    out = capsys.readouterr().out
    assert "field of view (estimated): 14.99" in out or "field of view (estimated): 15.00" in out


def test_cli_star_lists_with_no_field_are_one_batch_that_learns_it(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    # Seeds 2, 7 and 11 are not identified alone (ten false spots each); among their camera's
    # other frames, whose field the batch learns, they are.
    deep = starid.Catalog.deep(9.0)
    files = []
    for s in range(12):
        f = starid.simulate(deep, 12.0, (1024, 768), seed=s, mag_limit=7.0, noise_px=0.3, mag_noise=0.2, false_stars=10)
        files.append(tmp_path / f"f{s:02d}.csv")
        np.savetxt(files[-1], np.column_stack([f.xy, f.magnitudes]), delimiter=",", header="x,y,mag", comments="")
    assert main(["identify", str(files[2]), "--size", "1024x768"]) == 1
    capsys.readouterr()
    assert main(["identify", *map(str, files), "--size", "1024x768"]) == 0
    assert "12/12 frames identified" in capsys.readouterr().out


def test_simulated_radial_distortion_is_recovered(bundled: starid.Catalog) -> None:
    frame = starid.simulate(bundled, 16.0, (1024, 1024), seed=5, radial_k1=-0.08)
    res = starid.identify(frame.xy, bundled, fov_deg=16.0, image_size=(1024, 1024))
    assert res.ok
    fit = sp.refine(res, frame.xy, bundled, (1024, 1024), fit_k1=True)
    assert fit.k1 == pytest.approx(-0.08, abs=1e-9)
    assert fit.focal_px == pytest.approx(starid.Camera((1024, 1024), 16.0).focal_length_px, rel=1e-9)
    with pytest.raises(ValueError, match="radial_k1"):
        starid.simulate(bundled, 16.0, (1024, 1024), seed=5, radial_k1=float("nan"))


def test_huge_inputs_are_refused_or_handled() -> None:
    rng = np.random.default_rng(0)
    radec = np.column_stack([rng.uniform(0, 360, 2000), rng.uniform(-80, 80, 2000)])
    with pytest.raises(ValueError, match="at most 1000"):
        sp.boresight_from_distances(radec, np.ones(2000), focal_px=1000.0)
    # Refinement over many stars stays linear: 20 000 matched stars of a synthetic frame.
    f = 2000.0
    off = rng.uniform(-500, 500, (20_000, 2))
    rays = np.column_stack([off, np.full(len(off), f)])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    radec = np.column_stack([np.degrees(np.arctan2(rays[:, 1], rays[:, 0])) % 360, np.degrees(np.arcsin(rays[:, 2]))])
    fit = sp.fit_pointing(radec, off + 512, (1024, 1024), focal_px=f * 1.1)
    assert fit.converged and abs(fit.focal_px / f - 1) < 1e-9


def test_inconsistent_distances_are_flagged() -> None:
    stars = [[83.0, -1.0], [86.5, 2.0], [80.5, 3.0]]
    sols = sp.boresight_from_distances(stars, [10.0, 5000.0, 10.0], focal_px=2435.68)
    assert sols and sols[0].inconsistent and sols[0].rms_px > sp.INCONSISTENT_RMS_PX
    good = sp.boresight_from_distances(stars, [67.23, 142.72, 166.21], focal_px=2435.68)
    assert not good[0].inconsistent
