"""The ``starid`` command: identify star lists, calibrate a camera, simulate frames, describe catalogues."""

from __future__ import annotations

import argparse
import csv
import math
import json
import sys
import time
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from ._catalog import Catalog, resolve_catalog
from ._batch import identify_many
from .calibration import calibrate, load_camera
from . import guide, pointing
from ._args import METHODS, Camera, Identification
from ._identify import identify
from ._simulate import simulate
from ._errors import InvalidInputError
from ._cli_args import parser
from ._files import refuse_overwriting, write_atomically
from ._index_cache import clear_index_cache, index_cache_dir, index_cache_files
from .images import extract_centroids, simulate_image, warm_index
from .plot import annotate
from .tracking import Tracker
from .wcs import wcs_header
from .starlist import StarList, read_star_list

EXAMPLE_FRAME = Path(__file__).parent / "data" / "example_frame.csv"
EXAMPLE_FOV_DEG = 12.0
EXAMPLE_SIZE = (512.0, 512.0)


def _table(labels: Sequence[str], res: Identification) -> str:
    width = max([5] + [len(s) for s in labels])
    lines = [f"{'label':<{width}}  {'id':>8}  {'residual':>10}"]
    for label, cid, r in zip(labels, res.ids, res.residuals_arcsec):
        lines.append(f"{label:<{width}}  {cid:>8d}  " + (f"{r:>8.2f}\"" if cid >= 0 else f"{'-':>9}"))
    return "\n".join(lines)


BATCH = 256


def _progress(done: int, total: int, identified: Optional[int], elapsed_s: float, stage: str = "frames") -> None:
    """A one-line progress bar with the rate and the time left, on stderr (results go to stdout)."""
    width = 30
    filled = int(width * done / max(total, 1))
    rate = done / elapsed_s if elapsed_s > 0 else 0.0
    eta = (total - done) / rate if rate > 0 else float("nan")
    count = "" if identified is None else f", {identified} identified"
    print(
        f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {stage}{count}, {rate:,.0f}/s, "
        f"{'ETA ' + _duration(eta) if done < total else 'done in ' + _duration(elapsed_s)}   ",
        end="" if done < total else "\n",
        file=sys.stderr,
        flush=True,
    )


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m}:{s:02d}" if m < 60 else f"{m // 60}:{m % 60:02d}:{s:02d}"


def _write_wcs(out: Path, res: Identification, size: Optional[tuple[float, float]]) -> None:
    """The solution's WCS as a FITS header file (a header-only primary HDU, like solve-field's)."""
    try:
        from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError as e:
        raise ImportError("--wcs needs astropy: pip install 'starid-solver[fits]'") from None
    if size is None:
        raise ValueError("--wcs needs the image size")
    hdu = fits.PrimaryHDU(header=fits.Header(wcs_header(res, size)))
    _wrote(write_atomically(out, lambda tmp: hdu.writeto(tmp, overwrite=True)))


def _write_corr(out: Path, res: Identification) -> None:
    """The matched stars, one row per named spot (the per-spot table's rows with a catalogue
    id): CSV, or a FITS binary table for a .fits/.fit/.corr name, as solve-field's .corr file.
    x and y are starid's pixels (the first pixel's centre at 0.5); FITS pixels are x + 0.5."""
    rows = res.table()
    rows = rows[rows["catalog_id"] >= 0]
    if out.suffix.lower() in (".fits", ".fit", ".corr"):
        try:
            from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
        except ImportError:
            raise ImportError("a FITS --corr file needs astropy: pip install 'starid-solver[fits]'") from None
        hdu = fits.BinTableHDU(rows, name="CORR")
        _wrote(write_atomically(out, lambda tmp: hdu.writeto(tmp, overwrite=True)))
        return

    names = list(rows.dtype.names or ())

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(names)
            for r in rows:
                w.writerow([int(v) if k == "catalog_id" else repr(float(v)) for k, v in zip(names, r)])

    _wrote(write_atomically(out, write))


def _wrote(path: Path) -> None:
    """Say which file was written (on stderr: stdout carries the results)."""
    print(f"wrote {path}", file=sys.stderr)


_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".fits", ".fit", ".fts", ".fits.gz", ".fit.gz")


def _is_image_file(path: Path) -> bool:
    return path.name.lower().endswith(_IMAGE_SUFFIXES)


def _read_spots(path: Path) -> tuple[StarList, Optional[tuple[float, float]], tuple[float, float]]:
    """The spots of a star list, or of an image with its size, and the seconds spent reading and
    extracting them; ValueError naming the file when it cannot be read."""
    try:
        if _is_image_file(path):
            c = extract_centroids(path)
            mags = c.magnitudes if np.isfinite(c.magnitudes).all() else None
            return StarList([f"s{i}" for i in range(len(c))], c.xy, mags), c.image_size, (c.read_s, c.extract_s)
        t0 = time.perf_counter()
        stars = read_star_list(path)
        return stars, None, (time.perf_counter() - t0, 0.0)
    except UnicodeDecodeError as e:
        raise ValueError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except (ValueError, OSError, ImportError) as e:
        msg = str(e)
        raise ValueError(msg if str(path) in msg else f"{path}: {msg}") from None


def _geometry(camera: Optional[Camera], fov: Optional[float], size: Any) -> dict[str, Any]:
    """The camera arguments of an identification: a saved camera, or the field and size."""
    return {"camera": camera} if camera is not None else {"fov_deg": fov, "image_size": size}


def _calibrate(args: argparse.Namespace) -> int:
    files: list[Path] = list(args.files)
    refuse_overwriting([args.output], [*files, args.catalog, args.camera])
    star_lists, sizes = [], set()
    for path in files:
        stars, image_size, _ = _read_spots(path)
        star_lists.append(stars)
        sizes.add(image_size if image_size is not None else args.size)
    if args.camera is not None:
        if args.fov_deg is not None:
            print("starid calibrate: --camera replaces --fov-deg", file=sys.stderr)
            return 2
        start = load_camera(args.camera)
    else:
        if args.fov_deg is None:
            print("starid calibrate: give --fov-deg (the nominal field) or --camera", file=sys.stderr)
            return 2
        if None in sizes:
            print("starid calibrate: --size is required for star lists (images give their own)", file=sys.stderr)
            return 2
        if len(sizes) != 1:
            print(f"starid calibrate: the frames are of several sizes ({sorted(sizes)}): one camera at a time", file=sys.stderr)
            return 2
        start = Camera(sizes.pop(), args.fov_deg)
    mags = [s.magnitudes for s in star_lists]
    result = calibrate(
        [s.xy for s in star_lists],
        camera=start,
        catalog=args.catalog,  # None: the bundled catalogue deep enough for the field
        magnitudes=None if any(m is None for m in mags) else mags,
        mag_offset=None,
        principal_point=None if args.principal_point is None else args.principal_point == "yes",
        radial_terms=args.radial_terms,
        decentering=None if args.decentering is None else args.decentering == "yes",
        clip_sigma=args.clip_sigma,
    )
    if args.output is not None:
        result.save(args.output)
        _wrote(args.output)
    cam = result.camera
    if args.json:
        print(json.dumps({"camera": cam.to_dict(), **result.to_dict()}, indent=2))
        return 0
    before, after, total = result.identified or (0, 0, len(files))
    print(f"frames identified: {before}/{total} with the starting camera, {after}/{total} with the calibrated one")
    print(f"matches: {result.n_inliers} kept, {result.n_clipped} clipped as outliers")
    print(f"RMS residual per axis: {result.rms_before_px:.3f} px before, {result.rms_px:.3f} px after")
    values = {"focal_length_px": cam.focal_length_px, "cx": cam.principal_point[0], "cy": cam.principal_point[1],
              "k1": cam.k1, "k2": cam.k2, "k3": cam.k3, "p1": cam.p1, "p2": cam.p2}
    sig = result.sigmas
    for name, v in values.items():
        print(f"  {name:<16} {v:+.6g}" + (f"  +- {sig[name]:.2g}" if name in sig else "  (not fitted)"))
    return 0


def _identify(args: argparse.Namespace) -> int:
    files: list[Path] = list(args.files)
    fov, size = args.fov_deg, args.size
    camera = None
    if args.camera is not None:
        if fov is not None or size is not None or args.fov_range_deg is not None:
            print("starid identify: --camera replaces --fov-deg, --size and --fov-range-deg", file=sys.stderr)
            return 2
        camera = load_camera(args.camera)
        size = camera.image_size
    if args.example:
        files.append(EXAMPLE_FRAME)
        fov = EXAMPLE_FOV_DEG if fov is None else fov
        size = EXAMPLE_SIZE if size is None else size
    if not files:
        print("starid identify: give star-list files or --example", file=sys.stderr)
        return 2
    for option, value in (("--wcs", args.wcs), ("--corr", args.corr)):
        if value is not None and len(files) != 1:
            print(f"starid identify: {option} takes one file", file=sys.stderr)
            return 2
    images = {k for k, f in enumerate(files) if _is_image_file(f)}
    if args.annotate is not None and (len(files) != 1 or not images):
        print("starid identify: --annotate takes one image file", file=sys.stderr)
        return 2
    if size is None and len(images) < len(files):
        print("starid identify: --size is required for star lists (images give their own)", file=sys.stderr)
        return 2
    refuse_overwriting([args.wcs, args.annotate, args.corr], [*files, args.catalog])
    fov_range = None if args.fov_range_deg is None else tuple(sorted(args.fov_range_deg))
    # Without --catalog each camera gets the bundled catalogue deep enough for its field, as
    # starid.identify chooses it.
    catalog = None if args.catalog is None else resolve_catalog(args.catalog)
    results: list[dict[str, Any]] = []
    failures = 0
    # A progress bar on a terminal's stderr for long runs; the results go to stdout all the same.
    show_progress = len(files) > 20 and sys.stderr.isatty()
    t0 = time.perf_counter()
    # A file that cannot be read is reported (one line naming it) and the others go on.
    star_lists: list[Any] = []
    unreadable: dict[int, str] = {}
    sizes: dict[int, tuple[float, float]] = {}
    times: dict[int, tuple[float, float]] = {}
    # The first image's catalogue and index load on a thread of their own while it is read.
    warm = warm_index(files[min(images)], catalog, fov, {"camera": camera, "fov_range_deg": fov_range}) if images else None
    for k, path in enumerate(files):
        if show_progress and (k % 10 == 9 or k == len(files) - 1) and images:
            _progress(k + 1, len(files), None, time.perf_counter() - t0, "files read")
        try:
            stars, image_size, times[k] = _read_spots(path)
            star_lists.append(stars)
            if image_size is not None:
                sizes[k] = image_size
        except ValueError as e:
            unreadable[k] = str(e)
            star_lists.append(None)
    if warm is not None:
        warm.join()
    bad_input = 0

    def solve_one(k: int) -> Identification:
        stars = star_lists[k]
        return identify(
            stars.xy,
            catalog=catalog,
            **_geometry(camera, fov, sizes.get(k, size)),
            fov_range_deg=fov_range,
            magnitudes=None if args.no_magnitudes else stars.magnitudes,
            centroid_sigma_px=args.sigma_px,
            max_false_match_prob=args.max_false_prob,
            method=args.method,
            verify=not args.no_verify,
            focal_check=not args.fixed_fov,
            # An image's magnitudes are instrumental: their zero point is unknown.
            mag_offset=None if k in images else args.mag_offset,
        )

    solved: dict[int, Identification] = {}
    if len(files) - len(unreadable) >= 3:
        # Many frames of one camera: identified in batches on every core (Rust threads), with a
        # progress bar between batches; one batch per sensor size and kind of file, so that the
        # frames learn their magnitudes' zero point together (an image's is always unknown), and
        # their field of view where it is an estimate or not given.
        groups: dict[tuple[Any, bool], list[int]] = {}
        for k in range(len(files)):
            if k not in unreadable:
                groups.setdefault((sizes.get(k, size), k in images), []).append(k)
        for (group_size, are_images), members in groups.items():
            for lo in range(0, len(members), BATCH):
                chunk = members[lo : lo + BATCH]
                batch = identify_many(
                    [star_lists[k].xy for k in chunk],
                    catalog=catalog,
                    **_geometry(camera, fov, group_size),
                    fov_range_deg=fov_range,
                    magnitudes=None if args.no_magnitudes else [star_lists[k].magnitudes for k in chunk],
                    centroid_sigma_px=args.sigma_px,
                    max_false_match_prob=args.max_false_prob,
                    method=args.method,
                    verify=not args.no_verify,
                    focal_check=not args.fixed_fov,
                    mag_offset=None if are_images else args.mag_offset,
                )
                for k, r in zip(chunk, batch):
                    if r.status != "invalid_input":  # identified alone below, for its error line
                        solved[k] = r
                if show_progress:
                    _progress(len(solved), len(files), sum(r.ok for r in solved.values()), time.perf_counter() - t0)
    for n, path in enumerate(files):
        stars = star_lists[n]
        if n in unreadable:
            bad_input += 1
            print(f"starid: error: {unreadable[n]}", file=sys.stderr)
            if args.json:
                results.append({"file": str(path), "status": "invalid_input", "ok": False, "message": unreadable[n]})
            continue
        if n in solved:
            res = solved[n]
        else:
            try:
                res = solve_one(n)
            except ValueError as e:
                bad_input += 1
                print(f"starid: error: {path}: {e}", file=sys.stderr)
                if args.json:
                    results.append({"file": str(path), "status": "invalid_input", "ok": False, "message": str(e)})
                continue
            if show_progress:
                _progress(n + 1, len(files), n + 1 - failures - (not res.ok), time.perf_counter() - t0)
        failures += not res.ok
        if args.wcs is not None and res.ok:
            _write_wcs(args.wcs, res, sizes.get(n, size))
        if args.corr is not None and res.ok:
            _write_corr(args.corr, res)
        if args.annotate is not None:
            annotate(path, res, args.annotate, catalog=catalog, xy=stars.xy)
            _wrote(args.annotate.resolve())
        if args.json:
            d = res.to_dict()
            d["file"] = str(path)
            d["labels"] = stars.labels
            d["x"] = [float(v) for v in stars.xy[:, 0]]
            d["y"] = [float(v) for v in stars.xy[:, 1]]
            d["read_s"], d["extract_s"] = times[n]
            results.append(d)
        else:
            print(f"== {path}  ({len(stars.labels)} centroids)")
            print(_table(stars.labels, res))
            if res.ok and res.quaternion is not None:
                q = np.array2string(res.quaternion, precision=9, separator=", ")
                print(
                    f"attitude: ra {res.ra_deg:.6f} deg, dec {res.dec_deg:+.6f} deg, roll {res.roll_deg:.5f} deg, "
                    f"mirrored {res.mirrored}\nquaternion [w, x, y, z] (ICRS -> camera): {q}\n"
                    + (
                        f"identified {res.n_matched}/{len(res.ids)}, P(false match) <= {res.false_match_probability:.1e}, "
                        f"noise {res.centroid_sigma_px:.2f} px"
                        if res.verified
                        else f"named {res.n_matched}/{len(res.ids)} by {res.method}'s raw answer: NOT verified (--no-verify), ids may be wrong"
                    )
                    + (
                        f"\nfield of view (estimated): {res.fov_deg:.5f} deg, focal length {res.focal_px:.3f} "
                        f"+- {res.focal_sigma_px:.3f} px"
                        if fov is None
                        else f"\nfield of view corrected by the focal check: {res.fov_deg:.5f} deg (given {fov} deg), "
                        f"focal length {res.focal_px:.3f} +- {res.focal_sigma_px:.3f} px"
                        if not math.isnan(res.focal_sigma_px)
                        else ""
                    )
                    + (f"\nlens distortion found: k1 {res.k1:+.4f}" if res.k1 != 0.0 else "")
                    + (f"\nmagnitude zero point learned from the other frames: {res.learned_mag_offset:+.3f} mag"
                       if res.learned_mag_offset is not None else "")
                )
            else:
                print(f"not identified ({res.status})")
            read_s, extract_s = times[n]
            print(
                f"time: read {read_s * 1e3:.3f} ms"
                + (f", extract {extract_s * 1e3:.3f} ms" if n in images else "")
                + f", identify {res.time_s * 1e3:.3f} ms\n"
            )
    if args.json:
        json.dump(results if len(results) != 1 else results[0], sys.stdout, indent=2)
        print()
    elif len(files) > 1:
        print(f"{len(files) - failures - bad_input}/{len(files)} frames identified in {time.perf_counter() - t0:.3f} s")
    # Exit codes: 0 every frame identified, 1 some frame not identified, 2 some input malformed.
    return 2 if bad_input else (0 if failures == 0 else 1)


def _simulate(args: argparse.Namespace) -> int:
    if (args.output is None) == (args.image is None):
        print("starid simulate: give a star list to write, or --image OUT", file=sys.stderr)
        return 2
    refuse_overwriting([args.output, args.image], [args.catalog])
    if args.image is not None:
        return _simulate_image(args)
    frame = simulate(
        resolve_catalog(args.catalog),
        fov_deg=args.fov_deg,
        image_size=args.size,
        attitude_deg=None if args.attitude_deg is None else tuple(args.attitude_deg),
        seed=args.seed,
        mag_limit=args.mag_limit,
        noise_px=args.noise_px,
        mag_noise=args.mag_noise,
        false_stars=args.false_stars,
        drop_fraction=args.drop_fraction,
        mirrored=args.mirrored,
    )

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(["label", "x", "y", "mag"])
            for i, ((x, y), m) in enumerate(zip(frame.xy, frame.magnitudes)):
                w.writerow([f"s{i}", f"{x:.4f}", f"{y:.4f}", f"{m:.3f}"])

    _wrote(write_atomically(args.output, write, [args.catalog] if args.catalog is not None else []))
    truth = {
        "file": str(args.output),
        "seed": frame.seed,
        "ra_deg": frame.ra_deg,
        "dec_deg": frame.dec_deg,
        "roll_deg": frame.roll_deg,
        "mirrored": frame.mirrored,
        "true_ids": {f"s{i}": int(t) for i, t in enumerate(frame.true_ids)},
    }
    print(json.dumps(truth, indent=2))
    return 0


def _simulate_image(args: argparse.Namespace) -> int:
    """``simulate --image OUT``: the rendered frame, 16-bit, as PNG/TIFF or FITS."""
    if args.attitude_deg is not None or args.mirrored or args.drop_fraction or args.mag_noise:
        raise InvalidInputError("--image takes --fov-deg, --size, --seed, --mag-limit and --false-stars only")
    img, frame = simulate_image(
        resolve_catalog(args.catalog), args.fov_deg, args.size, seed=0 if args.seed is None else args.seed,
        mag_limit=6.0 if args.mag_limit is None else args.mag_limit, false_stars=args.false_stars,
    )
    out: Path = args.image
    if out.name.lower().endswith((".fits", ".fit", ".fts")):
        try:
            from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
        except ImportError:
            raise ImportError("a FITS image needs astropy: pip install 'starid-solver[fits]'") from None
        _wrote(write_atomically(out, lambda tmp: fits.PrimaryHDU(img).writeto(tmp, overwrite=True)))
    elif out.suffix.lower() in (".png", ".tif", ".tiff"):
        from PIL import Image

        fmt = "PNG" if out.suffix.lower() == ".png" else "TIFF"
        _wrote(write_atomically(out, lambda tmp: Image.fromarray(img).save(tmp, format=fmt)))
    else:
        raise InvalidInputError(f"{out}: an image name ends in .png, .tif, .tiff or .fits")
    truth = {
        "file": str(out),
        "seed": frame.seed,
        "ra_deg": frame.ra_deg,
        "dec_deg": frame.dec_deg,
        "roll_deg": frame.roll_deg,
        "fov_deg": frame.fov_deg,
        "stars": [
            {"x": float(x), "y": float(y), "catalog_id": int(t)} for (x, y), t in zip(frame.xy, frame.true_ids)
        ],
    }
    print(json.dumps(truth, indent=2))
    return 0


def _catalog_info(args: argparse.Namespace) -> int:
    if args.clear_index_cache:
        print(f"deleted {clear_index_cache()} index file(s) from {index_cache_dir()}")
    cat: Catalog = resolve_catalog(args.catalog)
    print(repr(cat))
    info = cat.index_info(args.fov_deg, args.size)
    print(
        f"pair index for {args.fov_deg:g} deg on {args.size[0]:g}x{args.size[1]:g} px: {info['pairs']} pairs "
        f"up to {info['max_angle_deg']:.2f} deg, {info['memory_bytes'] / 1e6:.2f} MB, "
        f"built or read in {info['build_time_s'] * 1e3:.1f} ms"
    )
    files = index_cache_files()
    where = f"index file {info['index_file']}" if info["index_file"] else "not kept on disk"
    print(
        f"{where}; index cache {index_cache_dir() or 'off'}: {len(files)} file(s), "
        f"{sum(size for _, size in files) / 1e6:.1f} MB"
    )
    return 0


def _boresight(args: argparse.Namespace) -> int:
    focal = args.focal_px
    if args.fov_deg is not None:
        if focal is not None or args.width is None:
            raise ValueError("give --focal-px, or --fov-deg with --width")
        focal = Camera((args.width, args.width), args.fov_deg).focal_length_px
    focal_range = None
    if args.fov_range_deg is not None:
        if focal is not None or args.width is None:
            raise ValueError("--fov-range-deg needs --width and no --focal-px / --fov-deg")
        lo, hi = sorted(args.fov_range_deg)
        focal_range = (
            Camera((args.width, args.width), hi).focal_length_px,
            Camera((args.width, args.width), lo).focal_length_px,
        )
    stars = np.array(args.star, dtype=float)
    sols = pointing.boresight_from_distances(stars[:, :2], stars[:, 2], focal_px=focal, focal_range_px=focal_range)
    if not sols:
        print("no solution in the given field-of-view range", file=sys.stderr)
        return 1
    if args.json:
        out = [
            {
                "ra_deg": s.ra_deg, "dec_deg": s.dec_deg, "focal_px": s.focal_px, "rms_px": s.rms_px,
                "best": s.best, "ambiguous": s.ambiguous, "degenerate": s.degenerate,
                "boresight_sigma_arcsec": None if s.degenerate else s.boresight_sigma_arcsec(args.sigma_px),
            }
            for s in sols
        ]
        json.dump(out, sys.stdout, indent=2)
        print()
        return 0
    print(f"{len(sols)} solution(s), best supported first ({'focal length given' if focal else 'focal length estimated'}):")
    for k, s in enumerate(sols):
        flags = [n for n, v in (("best", s.best), ("ambiguous", s.ambiguous), ("degenerate", s.degenerate)) if v]
        sigma = s.boresight_sigma_arcsec(args.sigma_px)
        print(
            f"  {k + 1}. ra {s.ra_deg:.6f} deg, dec {s.dec_deg:+.6f} deg, focal {s.focal_px:.3f} px, "
            f"rms misfit {s.rms_px:.3g} px, 1-sigma {sigma:.3g} arcsec at {args.sigma_px:g} px"
            + (f"  [{', '.join(flags)}]" if flags else "")
        )
    return 0


def _guide(args: argparse.Namespace) -> int:
    refuse_overwriting([getattr(args, "output", None)], [args.catalog])
    cat = resolve_catalog(args.catalog)
    if args.guide_command == "compare":
        rows = guide.compare(
            cat, fov_deg=args.fov_deg, trials=args.trials, level=args.level,
            cell_deg=args.cell_deg, field=args.field, seed=args.seed,
        )
        if args.json:
            clean = [{k: v for k, v in r.items() if k != "stars_per_field"} for r in rows]
            json.dump(clean, sys.stdout, indent=2)
            print()
            return 0
        print(
            f"{cat!r}; {args.field} field of {args.fov_deg:g} deg, {args.trials} random pointings; "
            f"QTM level {args.level} ({guide.qtm_triangle_count(args.level)} triangles), "
            f"{args.cell_deg:g} deg rectangles"
        )
        print(guide.format_comparison(rows, paper=True))
        print("paper: contest catalogue (4908 stars), 10 deg field; its P(>=3) needs a wider field "
              "than a 10 deg circle (see the README)")
        return 0
    if args.guide_command == "select":
        params: dict[str, Any] = {}
        for name in ("mag_limit", "separation_deg", "cell_deg", "level"):
            value = getattr(args, name)
            if value is not None:
                params[name] = value
        if args.method == "doubles":
            params["merge"] = args.merge
        sel_cat = guide.select(cat, args.method, **params)
        sel_cat.to_csv(args.output)
        m = guide.metrics(sel_cat, args.fov_deg)
        print(
            f"{len(sel_cat)} guide stars written to {args.output}; nearest neighbour "
            f"min {m['nn_min_deg']:.4f} mean {m['nn_mean_deg']:.4f} std {m['nn_std_deg']:.4f} deg; "
            f"P(>=3 in a {args.fov_deg:g} deg circle) {100 * m['p_at_least_3']:.2f}%"
        )
        return 0
    selections = {
        f"rectangle {args.cell_deg:g} deg": guide.select(cat, "rectangle", cell_deg=args.cell_deg),
        f"QTM level {args.level}": guide.select(cat, "qtm", level=args.level),
        f"QTM level {args.level} weighted": guide.select(cat, "qtm-weighted", level=args.level),
    }
    guide.plot(selections, args.output, title=repr(cat), dpi=args.dpi)
    _wrote(args.output.resolve())
    return 0


def _track(args: argparse.Namespace) -> int:
    files: list[Path] = list(args.files)
    if args.times is not None:
        try:
            times = [float(t) for t in args.times.split(",")]
        except ValueError:
            print(f"starid track: --times takes numbers separated by commas, got {args.times!r}", file=sys.stderr)
            return 2
        if len(times) != len(files):
            print(f"starid track: {len(times)} times for {len(files)} files", file=sys.stderr)
            return 2
    else:
        if not (args.frame_rate_hz > 0 and args.frame_rate_hz < float("inf")):
            print(f"starid track: --frame-rate-hz must be positive, got {args.frame_rate_hz}", file=sys.stderr)
            return 2
        times = [k / args.frame_rate_hz for k in range(len(files))]
    tracker = Tracker(resolve_catalog(args.catalog), args.fov_deg, args.size, max_rate_deg_s=args.max_rate_deg_s)
    show_progress = len(files) > 20 and sys.stderr.isatty()
    t0 = time.perf_counter()
    failures = bad_input = identified = 0
    for k, (path, t) in enumerate(zip(files, times)):
        # A file that cannot be read, or a frame the tracker refuses (a spot off the sensor, a
        # time that is not a number), is reported naming it, and the frames after it go on.
        try:
            stars, _, _ = _read_spots(path)
            step = tracker.update(stars.xy, t, magnitudes=None if args.no_magnitudes else stars.magnitudes)
        except ValueError as e:
            msg = str(e)
            print(f"starid track: {msg if str(path) in msg else f'{path}: {msg}'}", file=sys.stderr)
            bad_input += 1
            if args.json:
                print(json.dumps({"file": str(path), "t_s": t, "status": "invalid_input", "ok": False, "message": msg}))
            continue
        res = step.identification
        identified += int(res.ok)
        failures += int(not res.ok)
        if args.json:
            d = res.to_dict()
            d.update(file=str(path), t_s=t, mode=step.mode, uncertainty_deg=None if step.uncertainty_deg != step.uncertainty_deg else step.uncertainty_deg,
                     rate_deg_s=None if step.rate_deg_s is None else [float(v) for v in step.rate_deg_s])
            print(json.dumps(d))
        else:
            att = f"RA {res.ra_deg:.4f} Dec {res.dec_deg:.4f} roll {res.roll_deg:.3f}" if res.ok else res.status
            print(f"{path}  t={t:.3f}s  {step.mode:<13}  {res.n_matched:>3} stars  {att}  {1e6 * res.time_s:.0f} us")
        if show_progress and (k % 50 == 49 or k == len(files) - 1):
            _progress(k + 1, len(files), identified, time.perf_counter() - t0)
    if bad_input:
        return 2
    return 1 if failures else 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``starid`` command."""
    args = parser().parse_args(argv)
    try:
        if args.command == "identify":
            return _identify(args)
        if args.command == "simulate":
            return _simulate(args)
        if args.command == "guide":
            return _guide(args)
        if args.command == "boresight":
            return _boresight(args)
        if args.command == "track":
            return _track(args)
        if args.command == "calibrate":
            return _calibrate(args)
        if args.command == "methods":
            width = max(map(len, METHODS))
            for name, text in METHODS.items():
                print(f"{name:<{width}}  {text}")
            return 0
        return _catalog_info(args)
    except BrokenPipeError:
        # The reader went away (e.g. `starid ... | head`): not an error of ours.
        sys.stdout = None
        return 0
    except (ValueError, OSError, ImportError) as e:
        print(f"starid: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
