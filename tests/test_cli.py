from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import starid
from starid.cli import main


def test_example(capsys: object) -> None:
    assert main(["identify", "--example"]) == 0
    out = capsys.readouterr().out  # type: ignore[attr-defined]
    assert "attitude: ra 83.0" in out and "time:" in out


def test_json_and_module_entry(tmp_path: Path) -> None:
    truth_out = subprocess.run(
        [sys.executable, "-m", "starid", "simulate", str(tmp_path / "f.csv"), "--seed", "4", "--noise-px", "0.3"],
        check=True, capture_output=True, text=True,
    ).stdout
    truth = json.loads(truth_out)
    out = subprocess.run(
        [sys.executable, "-m", "starid", "identify", str(tmp_path / "f.csv"), "--fov-deg", "12", "--size", "512x512", "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    res = json.loads(out)
    assert res["ok"] and abs(res["dec_deg"] - truth["dec_deg"]) < 0.01
    for label, cid in zip(res["labels"], res["ids"]):
        assert cid in (-1, truth["true_ids"][label])


def test_star_list_layouts(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("1.5 2.5\n3 4\n")
    (tmp_path / "b.csv").write_text("label,x,y,mag\nA,1,2,3.5\n")
    (tmp_path / "c.csv").write_text("X,Y,Name\n5,6,q\n")
    assert starid.read_star_list(tmp_path / "a.txt").xy.tolist() == [[1.5, 2.5], [3, 4]]
    b = starid.read_star_list(tmp_path / "b.csv")
    assert b.labels == ["A"] and b.magnitudes is not None and b.magnitudes.tolist() == [3.5]
    assert starid.read_star_list(tmp_path / "c.csv").labels == ["q"]


def test_cli_errors(tmp_path: Path, capsys: object) -> None:
    (tmp_path / "bad.csv").write_text("x,y\n1,oops\n")
    assert main(["identify", str(tmp_path / "bad.csv"), "--fov-deg", "12", "--size", "512x512"]) == 2
    assert main(["identify", str(tmp_path / "missing.csv"), "--fov-deg", "12", "--size", "512x512"]) == 2
    assert main(["identify", str(tmp_path / "bad.csv")]) == 2
    np.savetxt(tmp_path / "few.txt", [[1, 2], [3, 4]])
    # Two centroids are an observation (status too_few_stars), not bad input: exit 1, not identified.
    assert main(["identify", str(tmp_path / "few.txt"), "--fov-deg", "12", "--size", "512x512"]) == 1


def test_many_files_are_identified_in_batches(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    paths = []
    for seed in range(25):
        p = tmp_path / f"f{seed}.csv"
        assert main(["simulate", str(p), "--seed", str(seed), "--noise-px", "0.2"]) == 0
        paths.append(str(p))
    capsys.readouterr()
    assert main(["identify", *paths, "--fov-deg", "12", "--size", "512x512"]) == 0
    out = capsys.readouterr().out
    assert out.count("== ") == 25
    assert "25/25 frames identified" in out
    # On a terminal, a progress bar goes to stderr; the results still go to stdout, the same.
    import sys

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sys.stderr, "isatty", lambda: True)
        assert main(["identify", *paths, "--fov-deg", "12", "--size", "512x512"]) == 0
    both = capsys.readouterr()
    assert both.out.count("== ") == 25 and "25/25 frames" in both.err and "done in" in both.err


def test_methods_and_method_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from starid.cli import main

    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    assert "pyramid" in out and "voting" in out
    for name in ("angular-distance", "star-line-angle", "angle-sum", "distance-vote", "radial-vote"):
        assert name in out
    f = tmp_path / "frame.csv"
    assert main(["simulate", str(f), "--seed", "3", "--mag-limit", "6"]) == 0
    capsys.readouterr()
    assert main(["identify", str(f), "--fov-deg", "12", "--size", "512x512", "--method", "voting", "--json"]) == 0
    assert '"method": "voting"' in capsys.readouterr().out
    assert main(["identify", str(f), "--fov-deg", "12", "--size", "512x512", "--method", "distance-vote", "--json"]) == 0
    out = capsys.readouterr().out
    assert '"method": "distance-vote"' in out and '"verified": true' in out
    assert main(["identify", str(f), "--fov-deg", "12", "--size", "512x512", "--method", "angle-sum", "--no-verify", "--sigma-px", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "NOT verified" in out or "not identified" in out


def test_a_bad_file_does_not_stop_the_others(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = tmp_path / "good.csv"
    assert main(["simulate", str(good), "--seed", "3", "--mag-limit", "6"]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,oops\n")
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"x,y\n\xff\xfe,1\n")
    capsys.readouterr()
    code = main(["identify", str(bad), str(good), str(binary), "--fov-deg", "12", "--size", "512x512"])
    out, err = capsys.readouterr()
    assert code == 2  # malformed input somewhere
    assert f"== {good}" in out and "1/3 frames identified" in out
    assert str(bad) in err and str(binary) in err and "UTF-8" in err
    assert "Traceback" not in err
    # A malformed catalogue: one line naming it, exit code 2.
    cat = tmp_path / "cat.csv"
    cat.write_text("id,ra_deg,dec_deg,mag\n1,10,oops,3\n")
    assert main(["identify", str(good), "--fov-deg", "12", "--size", "512x512", "--catalog", str(cat)]) == 2
    assert "cat.csv" in capsys.readouterr().err


def test_a_field_of_view_given_off_is_corrected_unless_held_fixed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    frame = tmp_path / "f20.csv"
    main(["simulate", str(frame), "--fov-deg", "20", "--size", "1024x1024", "--seed", "0", "--mag-limit", "6", "--noise-px", "0.2"])
    capsys.readouterr()
    args = ["identify", str(frame), "--fov-deg", "20.2", "--size", "1024x1024"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "corrected by the focal check: 20.00" in out and "identified 34/34" in out
    assert main([*args, "--fixed-fov"]) == 0
    assert "corrected" not in capsys.readouterr().out
    assert main([*args, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert abs(res["fov_deg"] - 20.0) < 0.01 and res["focal_sigma_px"] > 0


def test_many_files_learn_their_magnitudes_zero_point(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Kelvins-style scenes whose magnitudes carry an instrument zero point (5 mag): the frames
    # identified from the brightness order measure it, and the rest are searched with it.
    paths, truth = [], []
    for seed in range(12):
        f = starid.simulate_scene("K1", seed=seed)
        p = tmp_path / f"k{seed}.csv"
        rows = "".join(f"s{i},{x:.6f},{y:.6f},{m + 5.0:.4f}\n" for i, ((x, y), m) in enumerate(zip(f.xy, f.magnitudes)))
        p.write_text("label,x,y,mag\n" + rows)
        paths.append(str(p))
        truth.append(f.true_ids)
    assert main(["identify", *paths, "--fov-deg", "10", "--size", "1920x1440", "--json"]) in (0, 1)
    res = json.loads(capsys.readouterr().out)
    learned = [r["learned_mag_offset"] for r in res if r["learned_mag_offset"] is not None]
    assert len(learned) >= 2 and all(abs(z - 5.0) < 0.1 for z in learned)
    for r, ids in zip(res, truth):
        named = np.array(r["ids"]) >= 0
        assert np.array_equal(np.array(r["ids"])[named], ids[named])


def test_a_lens_distortion_found_is_printed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = starid.simulate(fov_deg=20.0, image_size=(1024, 1024), seed=0, noise_px=0.2, mag_limit=6.0, radial_k1=-0.2)
    p = tmp_path / "f.csv"
    p.write_text("x,y,mag\n" + "".join(f"{x:.5f},{y:.5f},{m:.3f}\n" for (x, y), m in zip(f.xy, f.magnitudes)))
    assert main(["identify", str(p), "--fov-deg", "20", "--size", "1024x1024"]) == 0
    out = capsys.readouterr().out
    k1 = float(out.split("lens distortion found: k1 ")[1].split()[0])
    assert abs(k1 + 0.2) < 0.05
    assert main(["identify", str(p), "--fov-deg", "20", "--size", "1024x1024", "--fixed-fov"]) == 0
    assert "lens distortion found" not in capsys.readouterr().out
