"""starid.guide: selections against independent numpy references, metrics, the paper's table."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import starid
import starid.guide as guide
from starid.cli import main


# ------------------------------------------------------------------ independent references
def _unit(cat: starid.Catalog) -> np.ndarray:
    ra, dec = np.radians(cat.ra_deg), np.radians(cat.dec_deg)
    return np.stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)], axis=1)


def _qtm_reference(v: np.ndarray, level: int) -> tuple[int, np.ndarray]:
    """QTM triangle of one direction: octant, then the child whose three edges hold v inside."""
    s = np.where(v < 0, -1.0, 1.0)
    tri = np.array([[s[0], 0, 0], [0, s[1], 0], [0, 0, s[2]]], dtype=float)
    key = (int(v[0] < 0), int(v[1] < 0), int(v[2] < 0))
    path: list[int] = list(key)
    for _ in range(level - 1):
        a, b, c = tri
        ab, bc, ca = ((a + b) / np.linalg.norm(a + b), (b + c) / np.linalg.norm(b + c), (c + a) / np.linalg.norm(c + a))
        children = [np.array(t) for t in ([a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca])]
        for k, t in enumerate(children):
            inside = all(
                np.dot(v, np.cross(t[i], t[(i + 1) % 3])) * np.dot(t[(i + 2) % 3], np.cross(t[i], t[(i + 1) % 3])) >= 0
                for i in range(3)
            )
            if inside:
                path.append(k)
                tri = t
                break
        else:  # pragma: no cover - the four children tile the parent
            raise AssertionError("point in no child")
    return hash(tuple(path)), tri


def _best_per_cell(cells: list, score: np.ndarray) -> set[int]:
    best: dict = {}
    for i, c in enumerate(cells):
        if c not in best or (score[i], i) < (score[best[c]], best[c]):
            best[c] = i
    return set(best.values())


def _rectangle_reference(cat: starid.Catalog, cell_deg: float) -> set[int]:
    n_ra, n_dec = int(np.ceil(360 / cell_deg)), int(np.ceil(180 / cell_deg))
    ra_cell = np.minimum((cat.ra_deg // cell_deg).astype(int), n_ra - 1)
    dec_cell = np.minimum(((cat.dec_deg + 90) // cell_deg).astype(int), n_dec - 1)
    cells = list(zip(dec_cell.tolist(), ra_cell.tolist()))
    return {int(cat.ids[i]) for i in _best_per_cell(cells, cat.mag)}


def _qtm_ids_reference(cat: starid.Catalog, level: int, weighted: bool) -> set[int]:
    v = _unit(cat)
    cells, score = [], cat.mag.copy()
    for i in range(len(cat)):
        key, tri = _qtm_reference(v[i], level)
        cells.append(key)
        if weighted:
            a, b, c = tri
            w = np.linalg.norm(b - c) * a + np.linalg.norm(c - a) * b + np.linalg.norm(a - b) * c
            w /= np.linalg.norm(w)
            score[i] += np.degrees(np.arccos(np.clip(np.dot(v[i], w), -1, 1)))
    return {int(cat.ids[i]) for i in _best_per_cell(cells, score)}


# ------------------------------------------------------------------ selections
def test_rectangle_matches_reference(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "rectangle", cell_deg=5.0)
    assert set(sel.ids.tolist()) == _rectangle_reference(contest, 5.0)
    assert len(sel) <= 72 * 36


@pytest.mark.parametrize("method", ["qtm", "qtm-weighted"])
def test_qtm_matches_reference(bundled: starid.Catalog, method: str) -> None:
    sub = bundled.filter(4.5)
    sel = guide.select(sub, method, level=4)
    assert set(sel.ids.tolist()) == _qtm_ids_reference(sub, 4, weighted=method == "qtm-weighted")
    assert len(sel) <= guide.qtm_triangle_count(4) == 512


def test_selection_keeps_catalogue_rows(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "qtm-weighted", level=5)
    rows = {int(i): k for k, i in enumerate(contest.ids)}
    idx = np.array([rows[int(i)] for i in sel.ids])
    assert np.all(np.diff(idx) > 0), "input order is kept"
    np.testing.assert_array_equal(sel.ra_deg, contest.ra_deg[idx])
    np.testing.assert_array_equal(sel.mag, contest.mag[idx])
    # Selecting again from the selection changes nothing: one star per triangle already.
    again = guide.select(sel, "qtm-weighted", level=5)
    np.testing.assert_array_equal(again.ids, sel.ids)


def test_paper_table_reproduced(contest: starid.Catalog) -> None:
    """Counts and nearest-neighbour means within 5 % of the published table."""
    rows = {r["method"]: r for r in guide.compare(contest, trials=20_000)}
    for ref in guide.PAPER_TABLE:
        row = rows[ref.method]
        assert abs(row["count"] - ref.count) <= 0.05 * ref.count, (ref.method, row["count"])
        assert abs(row["nn_mean_deg"] - ref.nn_mean_deg) <= 0.05 * ref.nn_mean_deg
        assert abs(row["nn_std_deg"] - ref.nn_std_deg) <= 0.15 * ref.nn_std_deg
    # The paper's ordering: weighting spreads the stars (larger mean, smaller spread).
    assert rows["qtm-weighted"]["nn_mean_deg"] > rows["qtm"]["nn_mean_deg"] > rows["rectangle"]["nn_mean_deg"]
    assert rows["qtm-weighted"]["nn_std_deg"] < rows["qtm"]["nn_std_deg"] < rows["rectangle"]["nn_std_deg"]
    assert "paper" in guide.format_comparison(list(rows.values()))


def test_magnitude_and_doubles(contest: starid.Catalog) -> None:
    bright = guide.select(contest, "magnitude", mag_limit=4.0)
    assert len(bright) == int(np.sum(contest.mag <= 4.0)) and bright.mag.max() <= 4.0
    sep = 0.25
    thin = guide.select(contest, "doubles", separation_deg=sep)
    v = _unit(thin)
    pairs = cKDTree(v).query_pairs(2 * np.sin(np.radians(sep) / 2))
    assert not pairs, "no two kept stars closer than the separation"
    removed = len(contest) - len(thin)
    assert removed > 0
    merged = guide.select(contest, "doubles", separation_deg=sep, merge=True)
    np.testing.assert_array_equal(merged.ids, thin.ids)
    assert np.all(merged.mag <= thin.mag + 1e-12) and np.any(merged.mag < thin.mag - 0.01)
    # Total flux is conserved by merging.
    flux = lambda m: np.sum(10 ** (-0.4 * m))  # noqa: E731
    assert flux(merged.mag) == pytest.approx(flux(contest.mag), rel=1e-9)


# ------------------------------------------------------------------ metrics
def test_nearest_neighbours_match_kdtree(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "rectangle")
    nn = guide.nearest_neighbour_deg(sel)
    d, _ = cKDTree(_unit(sel)).query(_unit(sel), k=2)
    want = np.degrees(2 * np.arcsin(d[:, 1] / 2))
    np.testing.assert_allclose(nn, want, atol=1e-9)
    m = guide.metrics(sel, trials=1000)
    assert m["nn_min_deg"] == pytest.approx(want.min())
    assert m["nn_mean_deg"] == pytest.approx(want.mean())
    assert m["nn_std_deg"] == pytest.approx(want.std())


def test_field_probability_matches_numpy_monte_carlo(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "qtm-weighted")
    m = guide.metrics(sel, fov_deg=10.0, trials=50_000)
    rng = np.random.default_rng(1)
    p = rng.normal(size=(20_000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    counts = (p @ _unit(sel).T >= np.cos(np.radians(5.0))).sum(axis=1)
    want = float(np.mean(counts >= 3))
    # Two independent estimates of the same probability: within 4 binomial sigmas.
    sigma = np.sqrt(want * (1 - want) * (1 / 20_000 + 1 / 50_000))
    assert abs(m["p_at_least_3"] - want) < 4 * sigma
    assert m["mean_stars_per_field"] == pytest.approx(counts.mean(), rel=0.03)
    assert m["stars_per_field"].sum() == m["trials"] == 50_000
    assert m["p_at_least"][3] == m["p_at_least_3"]
    assert all(m["p_at_least"][k] >= m["p_at_least"][k + 1] for k in range(1, 10))
    # Same seed, same figures; a different seed, (almost surely) different ones.
    assert guide.metrics(sel, trials=50_000)["p_at_least_3"] == m["p_at_least_3"]


def test_pair_count_is_the_index_size(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "rectangle")
    m = guide.metrics(sel, fov_deg=12.0, trials=100)
    u = _unit(sel)
    cos = u @ u.T
    want = int((np.triu(cos >= np.cos(np.radians(12.0)), k=1)).sum())
    assert abs(m["pairs"] - want) <= 2  # rounding at the boundary only
    # Two 16-bit star indices per pair (catalogues under 65 536 stars), plus the k-vector (a
    # 32-bit count per eight pairs).
    assert 4 * m["pairs"] < m["index_bytes"] <= 4.5 * m["pairs"] + 8


def test_square_field_holds_more_than_its_inscribed_circle(contest: starid.Catalog) -> None:
    sel = guide.select(contest, "qtm")
    circle = guide.metrics(sel, fov_deg=10.0, trials=20_000)
    square = guide.metrics(sel, fov_deg=10.0, trials=20_000, field="square")
    ratio = square["mean_stars_per_field"] / circle["mean_stars_per_field"]
    assert ratio == pytest.approx(4 / np.pi, rel=0.05)
    fov = guide.fov_for_coverage(sel, p=0.999, trials=20_000)
    assert 12.0 < fov < 18.0


@given(
    n=st.integers(min_value=2, max_value=400),
    level=st.integers(min_value=1, max_value=6),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_qtm_selection_properties(n: int, level: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1, 1, n)
    cat = starid.Catalog(
        np.arange(1, n + 1), rng.uniform(0, 360, n), np.degrees(np.arcsin(z)), rng.uniform(0, 6, n)
    )
    for method in ("qtm", "qtm-weighted"):
        sel = guide.select(cat, method, level=level)
        assert 1 <= len(sel) <= min(n, guide.qtm_triangle_count(level))
        assert set(sel.ids.tolist()) <= set(cat.ids.tolist())
        np.testing.assert_array_equal(guide.select(sel, method, level=level).ids, sel.ids)
    brightest = guide.select(cat, "qtm", level=level)
    # The brightest star of the sky is always kept by the brightest-per-triangle rule.
    assert int(cat.ids[np.argmin(cat.mag)]) in brightest.ids.tolist()


# ------------------------------------------------------------------ errors and CLI
@pytest.mark.parametrize(
    "call, message",
    [
        (lambda c: guide.select(c, "hexagon"), "unknown selection method"),
        (lambda c: guide.select(c, "magnitude"), "needs mag_limit"),
        (lambda c: guide.select(c, "qtm", level=0), "level"),
        (lambda c: guide.select(c, "qtm", level=21), "level"),
        (lambda c: guide.select(c, "qtm", level=2.5), "integer"),
        (lambda c: guide.select(c, "qtm", cell_deg=5), "takes"),
        (lambda c: guide.select(c, "rectangle", cell_deg=0.0), "cell size"),
        (lambda c: guide.select(c, "rectangle", cell_deg=float("nan")), "finite"),
        (lambda c: guide.select(c, "doubles", separation_deg=-1.0), "separation"),
        (lambda c: guide.select(c, "magnitude", mag_limit=-30.0), "no star"),
        (lambda c: guide.metrics(c, fov_deg=0.0), "field of view"),
        (lambda c: guide.metrics(c, fov_deg=200.0), "field of view"),
        (lambda c: guide.metrics(c, fov_deg=float("inf")), "finite"),
        (lambda c: guide.metrics(c, trials=0), "trials"),
        (lambda c: guide.metrics(c, trials=10**12), "trials"),
        (lambda c: guide.metrics(c, field="hexagon"), "circle"),
        (lambda c: guide.metrics(c, seed=-1), "seed"),
        (lambda c: guide.metrics(starid.Catalog([1], [0.0], [0.0], [1.0])), "two stars"),
        (lambda c: guide.fov_for_coverage(c, p=1.5), "p must"),
    ],
)
def test_bad_input_is_a_value_error(bundled: starid.Catalog, call, message: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=message):
        call(bundled)


def test_cli_guide_compare_and_select(contest: starid.Catalog, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from conftest import CONTEST_CATALOG

    assert main(["guide", "compare", "--catalog", str(CONTEST_CATALOG), "--trials", "2000"]) == 0
    out = capsys.readouterr().out
    assert "qtm-weighted" in out and "paper" in out and "1794" in out
    dest = tmp_path / "guide.csv"
    assert main(["guide", "select", str(dest), "--catalog", str(CONTEST_CATALOG), "--method", "rectangle"]) == 0
    back = starid.Catalog.from_csv(dest)
    np.testing.assert_array_equal(back.ids, guide.select(contest, "rectangle").ids)
    assert main(["guide", "select", str(dest), "--method", "magnitude"]) == 2
    assert "needs mag_limit" in capsys.readouterr().err


def test_cli_guide_plot(tmp_path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("matplotlib")
    dest = tmp_path / "sky.png"
    assert main(["guide", "plot", str(dest)]) == 0
    assert dest.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"tol_deg": 0.0}, "tol_deg"),
        ({"tol_deg": float("nan")}, "tol_deg"),
        ({"lo_deg": 20.0, "hi_deg": 10.0}, "lo_deg"),
        ({"trials": 10**9}, "trials"),
    ],
)
def test_fov_for_coverage_refuses_what_would_not_end(kw: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        starid.guide.fov_for_coverage(starid.Catalog.default(), **kw)  # type: ignore[arg-type]


def test_metrics_trials_are_capped() -> None:
    with pytest.raises(ValueError, match="trials"):
        starid.guide.metrics(starid.Catalog.default(), fov_deg=12.0, trials=10**8)
