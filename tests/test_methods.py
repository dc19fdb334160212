"""The source documents' identification methods (SEEDS.md sections 1-6): each identifies clean
frames of both contest cameras, raw answers come back in the documented shape, and verified
answers are never wrong."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import starid
from starid import InvalidInputError

CONTEST = Path(__file__).parent / "data" / "guide_catalog_4908.csv"
SEED_METHODS = ["angular-distance", "star-line-angle", "angle-sum", "distance-vote", "radial-vote"]
CAMERAS = [(12.0, (512, 512)), (20.0, (1024, 1024))]


@pytest.fixture(scope="module")
def contest() -> starid.Catalog:
    return starid.Catalog.from_csv(CONTEST)


def _shuffled(frame: starid.Frame, seed: int) -> tuple[Any, Any]:
    """The frame's spots in random order: the documents had no magnitudes."""
    perm = np.random.default_rng(seed).permutation(len(frame.xy))
    return np.ascontiguousarray(frame.xy[perm]), frame.true_ids[perm]


def test_the_methods_are_listed() -> None:
    for m in SEED_METHODS:
        assert m in starid.METHODS and "baseline" in starid.METHODS[m]
    assert starid.IdentifyConfig(method="angle_sum").method == "angle-sum"  # '_' for '-'


@pytest.mark.parametrize("method", SEED_METHODS)
@pytest.mark.parametrize("fov,size", CAMERAS)
def test_each_method_identifies_clean_contest_frames(contest: starid.Catalog, method: str, fov: float, size: tuple[int, int]) -> None:
    ok = 0
    for seed in range(12):
        xy, truth = _shuffled(starid.simulate(contest, fov, size, seed=seed, noise_px=0.1), seed)
        res = starid.identify(xy, contest, fov, size, method=method)
        known = res.ids >= 0
        assert np.array_equal(res.ids[known], truth[known]), f"{method}: a wrong id"
        if res.ok:
            ok += 1
            assert res.verified and res.method == method and res.false_match_probability <= 1e-3
            assert res.n_matched == int((truth >= 0).sum())  # verification names every star
    # Neighbour features fail where a neighbour pair sits at the edge of the field.
    assert ok >= 9, f"{method} identified {ok}/12"


@pytest.mark.parametrize("method", [*SEED_METHODS, "pyramid", "voting", "auto"])
def test_raw_answers_have_the_documented_shape(contest: starid.Catalog, method: str) -> None:
    frame = starid.simulate(contest, 12.0, (512, 512), seed=5, noise_px=0.2)
    res = starid.identify(frame.xy, contest, 12.0, (512, 512), method=method, verify=False, centroid_sigma_px=0.2)
    assert res.status in ("identified", "no_match")
    assert res.verified is False
    assert res.ids.shape == (len(frame.xy),) and res.ids.dtype == np.int64
    assert res.residuals_arcsec.shape == (len(frame.xy),)
    named = res.ids >= 0
    assert res.n_matched == int(named.sum())
    assert set(res.ids[named]) <= set(contest.ids)
    assert np.isnan(res.residuals_arcsec[~named]).all()
    assert res.false_match_probability == 1.0  # no bound was computed
    assert np.isnan(res.centroid_sigma_px)
    if res.ok:
        assert res.n_matched >= 2 and res.quaternion is not None
    back = pickle.loads(pickle.dumps(res))
    assert back.verified is False and np.array_equal(back.ids, res.ids)
    assert res.to_dict()["verified"] is False


def test_raw_and_verified_agree_on_a_clean_frame(contest: starid.Catalog) -> None:
    frame = starid.simulate(contest, 20.0, (1024, 1024), seed=8, noise_px=0.1)
    raw = starid.identify(frame.xy, contest, 20.0, (1024, 1024), method="distance-vote", verify=False, centroid_sigma_px=0.2)
    ver = starid.identify(frame.xy, contest, 20.0, (1024, 1024), method="distance-vote")
    assert raw.ok and ver.ok and ver.verified
    named = raw.ids >= 0
    assert np.array_equal(raw.ids[named], ver.ids[named])


def test_verify_off_is_refused_where_it_has_no_meaning(contest: starid.Catalog) -> None:
    frame = starid.simulate(contest, 12.0, (512, 512), seed=2)
    with pytest.raises(InvalidInputError, match="verify"):
        starid.identify(frame.xy, contest, 12.0, (512, 512), verify=False, attitude_hint=frame.quaternion)
    with pytest.raises(InvalidInputError, match="verify"):
        starid.identify(frame.xy, contest, image_size=(512, 512), verify=False)
    cfg = starid.IdentifyConfig(verify=False, method="radial-vote")
    assert pickle.loads(pickle.dumps(cfg)) == cfg and cfg.to_dict()["verify"] is False


def test_method_databases(contest: starid.Catalog) -> None:
    sizes = {m: contest.method_index(m, 12.0, (512, 512)) for m in [*SEED_METHODS, "pyramid"]}
    assert sizes["radial-vote"]["bytes"] == 3 * len(contest)  # three ring counts a star: "KB order"
    assert sizes["radial-vote"]["bytes"] < sizes["angle-sum"]["bytes"] < sizes["star-line-angle"]["bytes"]
    assert sizes["star-line-angle"]["bytes"] < sizes["angular-distance"]["bytes"] == sizes["distance-vote"]["bytes"]
    assert all(s["build_time_s"] >= 0 for s in sizes.values())
    # The solver's memory counts the tables once they are built (the neighbour rows once).
    info = contest.index_info(12.0, (512, 512))
    tables = sizes["star-line-angle"]["bytes"] + sizes["angle-sum"]["bytes"] - 12 * len(contest) + sizes["radial-vote"]["bytes"]
    assert info["seed_tables_bytes"] == tables
    assert info["memory_bytes"] >= info["pair_index_bytes"] + tables
    with pytest.raises(starid.StaridError, match="unknown method"):
        contest.method_index("guess", 12.0, (512, 512))


@settings(max_examples=30, deadline=None)
@given(
    method=st.sampled_from(SEED_METHODS),
    camera=st.sampled_from(CAMERAS),
    seed=st.integers(0, 10**6),
    noise=st.sampled_from([0.0, 0.5, 1.0]),
    false_stars=st.integers(0, 4),
    drop=st.sampled_from([0.0, 0.2]),
    mirrored=st.booleans(),
)
def test_verified_answers_are_never_wrong(
    method: str, camera: tuple[float, tuple[int, int]], seed: int, noise: float, false_stars: int, drop: float, mirrored: bool
) -> None:
    contest = _contest()
    fov, size = camera
    frame = starid.simulate(
        contest, fov, size, seed=seed, noise_px=noise, false_stars=false_stars, drop_fraction=drop, mirrored=mirrored
    )
    xy, truth = _shuffled(frame, seed)
    if len(xy) < 4:
        return
    res = starid.identify(xy, contest, fov, size, method=method)
    known = res.ids >= 0
    assert np.array_equal(res.ids[known], truth[known])
    if res.ok:
        assert res.verified and res.mirrored == mirrored


_CONTEST: list[starid.Catalog] = []


def _contest() -> starid.Catalog:
    if not _CONTEST:
        _CONTEST.append(starid.Catalog.from_csv(CONTEST))
    return _CONTEST[0]
