"""The ``starid`` command's arguments: every subcommand, its options and their checks."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Optional

from ._args import METHODS
from ._starid import __version__


def _mag_offset(text: str) -> Optional[float]:
    if text.strip().lower() in ("unknown", "none"):
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--mag-offset takes a number or 'unknown', got {text!r}") from None


def _size(text: str) -> tuple[float, float]:
    try:
        w, h = text.lower().split("x")
        return float(w), float(h)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 512x512, got {text!r}") from None


def parser() -> argparse.ArgumentParser:
    """The command line of ``starid``: its subcommands and their options."""
    p = argparse.ArgumentParser(prog="starid", description="Lost-in-space star identification.")
    p.add_argument("--version", action="version", version=f"starid {__version__} (distribution starid-solver)")
    sub = p.add_subparsers(dest="command", required=True)

    ident = sub.add_parser("identify", help="identify the stars of centroid files")
    ident.add_argument("files", nargs="*", type=Path,
                       help="star lists (CSV or text, columns label,x,y[,mag] or x,y) or images (PNG, JPEG, TIFF, FITS)")
    ident.add_argument("--example", action="store_true", help="identify the bundled example frame (12 deg, 512x512)")
    ident.add_argument("--fov-deg", type=float, help="full field of view across the image width, degrees (omit if unknown)")
    ident.add_argument("--fov-range-deg", type=float, nargs=2, metavar=("LO", "HI"),
                       help="range searched when the field of view is unknown (default: 4 to 60, band by band)")
    ident.add_argument("--size", type=_size, help="sensor size WIDTHxHEIGHT in pixels, e.g. 512x512")
    ident.add_argument("--camera", type=Path, metavar="FILE",
                       help="the camera a calibration saved ('starid calibrate -o FILE'), instead of --fov-deg and --size")
    ident.add_argument("--catalog", type=Path,
                       help="catalogue file (CSV/TSV/text/.mat); default: bundled Hipparcos, as deep as the field needs")
    ident.add_argument("--sigma-px", type=float, help="centroid noise, 1 sigma in pixels (default: adaptive)")
    ident.add_argument("--max-false-prob", type=float, default=1e-3, help="largest accepted false-match bound")
    ident.add_argument("--no-magnitudes", action="store_true", help="ignore a magnitude column")
    ident.add_argument("--method", default="auto", choices=list(METHODS), help="how hypotheses are made (see 'starid methods')")
    ident.add_argument("--no-verify", action="store_true",
                       help="research only: print the method's raw answer without the shared verification (ids may be wrong)")
    ident.add_argument("--mag-offset", type=_mag_offset, default=0.0,
                       help="instrument minus catalogue magnitude (default 0), or 'unknown'")
    ident.add_argument("--fixed-fov", action="store_true",
                       help="hold --fov-deg fixed: no focal check (by default a solution whose residuals show the "
                            "field of view a little off is searched again with the focal length they imply)")
    ident.add_argument("--json", action="store_true", help="print JSON instead of tables")
    ident.add_argument("--annotate", type=Path, metavar="OUT",
                       help="write the image annotated with its identification as a PNG (one image file; needs matplotlib)")
    ident.add_argument("--wcs", type=Path, metavar="OUT",
                       help="write the FITS WCS header of the solution here, as solve-field does (one file; needs astropy)")
    ident.add_argument("--corr", type=Path, metavar="OUT",
                       help="write the matched stars here, one row per named spot, as solve-field's .corr: CSV, or a FITS "
                            "table for a .fits/.fit/.corr name (one file; FITS needs astropy)")

    sim = sub.add_parser("simulate", help="write a simulated star list (label,x,y,mag) or image, and print its truth")
    sim.add_argument("output", type=Path, nargs="?", help="the star list to write (CSV)")
    sim.add_argument("--image", type=Path, metavar="OUT",
                     help="render the frame as a 16-bit image instead: PNG or TIFF (Pillow), or FITS (astropy); "
                          "it takes --fov-deg, --size, --seed, --mag-limit and --false-stars")
    sim.add_argument("--fov-deg", type=float, default=12.0)
    sim.add_argument("--size", type=_size, default=(512.0, 512.0))
    sim.add_argument("--catalog", type=Path)
    sim.add_argument("--seed", type=int)
    sim.add_argument("--attitude-deg", type=float, nargs=3, metavar=("RA", "DEC", "ROLL"))
    sim.add_argument("--mag-limit", type=float, help="only catalogue stars with mag <= this appear")
    sim.add_argument("--noise-px", type=float, default=0.2)
    sim.add_argument("--mag-noise", type=float, default=0.0)
    sim.add_argument("--false-stars", type=int, default=0)
    sim.add_argument("--drop-fraction", type=float, default=0.0)
    sim.add_argument("--mirrored", action="store_true")

    cal = sub.add_parser("calibrate", help="fit one camera (focal length, principal point, distortion) to many frames of it")
    cal.add_argument("files", nargs="+", type=Path, help="star lists or images of one camera")
    cal.add_argument("--fov-deg", type=float, help="nominal field of view across the image width, degrees")
    cal.add_argument("--size", type=_size, help="sensor size WIDTHxHEIGHT in pixels (images give their own)")
    cal.add_argument("--camera", type=Path, metavar="FILE", help="start from a saved camera instead of --fov-deg")
    cal.add_argument("--catalog", type=Path, help="catalogue file; default: bundled Hipparcos")
    cal.add_argument("--radial-terms", type=int, choices=[0, 1, 2, 3], help="radial terms k1..k3 (default: chosen by the data)")
    cal.add_argument("--decentering", choices=["yes", "no"], help="fit p1, p2 (default: chosen by the data)")
    cal.add_argument("--principal-point", choices=["yes", "no"], help="fit the principal point (default: chosen by the data)")
    cal.add_argument("--clip-sigma", type=float, default=3.0, help="outlier clipping threshold in sigma (0: none)")
    cal.add_argument("-o", "--output", type=Path, metavar="FILE", help="write the camera as JSON (for --camera and starid.load_camera)")
    cal.add_argument("--json", action="store_true", help="print JSON instead of text")

    sub.add_parser("methods", help="list the identification methods (--method of identify)")
    info = sub.add_parser("catalog", help="describe a catalogue and its pair index")
    info.add_argument("catalog", type=Path, nargs="?", help="catalogue file; default: bundled Hipparcos")
    info.add_argument("--fov-deg", type=float, default=12.0)
    info.add_argument("--size", type=_size, default=(512.0, 512.0))
    info.add_argument(
        "--clear-index-cache",
        action="store_true",
        help="delete the pair-index files kept on disk (STARID_CACHE_DIR, else the user's cache directory) first",
    )

    bore = sub.add_parser(
        "boresight",
        help="the boresight (and focal length) from three or more stars' RA/Dec and image distances",
        description="Each star's image lies a distance a from the principal point, so the star is atan(a/f) "
        "from the boresight. Prints every solution, best supported first.",
    )
    bore.add_argument(
        "--star", nargs=3, type=float, action="append", required=True, metavar=("RA_DEG", "DEC_DEG", "DIST_PX"),
        help="a star and the distance of its image from the principal point (repeat, at least 3 times)",
    )
    bore.add_argument("--focal-px", type=float, help="focal length in pixels (default: estimated)")
    bore.add_argument("--fov-deg", type=float, help="field of view across --width, instead of --focal-px")
    bore.add_argument("--width", type=float, help="sensor width in pixels, with --fov-deg or --fov-range-deg")
    bore.add_argument("--fov-range-deg", type=float, nargs=2, metavar=("LO", "HI"),
                      help="with the focal length unknown: keep solutions whose field (across --width) is in this range")
    bore.add_argument("--sigma-px", type=float, default=0.1, help="centroid noise for the predicted precision")
    bore.add_argument("--json", action="store_true")

    guide = sub.add_parser("guide", help="guide-star catalogues: select, compare with the paper, plot")
    gsub = guide.add_subparsers(dest="guide_command", required=True)
    cmp_ = gsub.add_parser("compare", help="rectangle grid vs QTM vs weighted QTM, beside the paper's table")
    cmp_.add_argument("--catalog", type=Path, help="catalogue file; the paper used the 4908-star contest catalogue")
    cmp_.add_argument("--fov-deg", type=float, default=10.0, help="field: full cone angle (circle) or side (square)")
    cmp_.add_argument("--field", choices=("circle", "square"), default="circle")
    cmp_.add_argument("--trials", type=int, default=100_000, help="Monte Carlo fields")
    cmp_.add_argument("--level", type=int, default=5, help="QTM level (5: 2048 triangles)")
    cmp_.add_argument("--cell-deg", type=float, default=5.0, help="rectangle cell size (5: 2592 cells)")
    cmp_.add_argument("--seed", type=int, default=0)
    cmp_.add_argument("--json", action="store_true")
    sel = gsub.add_parser("select", help="write a guide catalogue as CSV and print its metrics")
    sel.add_argument("output", type=Path)
    sel.add_argument("--catalog", type=Path)
    sel.add_argument("--method", choices=("magnitude", "doubles", "rectangle", "qtm", "qtm-weighted"), default="qtm-weighted")
    sel.add_argument("--mag-limit", type=float, help="magnitude method: faintest kept magnitude")
    sel.add_argument("--separation-deg", type=float, help="doubles method: smallest separation kept")
    sel.add_argument("--merge", action="store_true", help="doubles method: merge instead of dropping")
    sel.add_argument("--cell-deg", type=float, help="rectangle method: cell size (default 5)")
    sel.add_argument("--level", type=int, help="QTM methods: mesh level (default 5)")
    sel.add_argument("--fov-deg", type=float, default=10.0, help="field for the metrics")
    trk = sub.add_parser("track", help="identify a recorded sequence of centroid files, each from the last ones' attitude")
    trk.add_argument("files", nargs="+", type=Path, help="star lists (CSV or text, label,x,y[,mag] or x,y) or images, in time order")
    when = trk.add_mutually_exclusive_group(required=True)
    when.add_argument("--times", help="frame times in seconds, comma-separated, one per file")
    when.add_argument("--frame-rate-hz", type=float, help="frames taken at this rate, the first at t = 0")
    trk.add_argument("--fov-deg", type=float, required=True, help="full field of view across the image width, degrees")
    trk.add_argument("--size", type=_size, required=True, help="sensor size WIDTHxHEIGHT in pixels")
    trk.add_argument("--catalog", type=Path, help="catalogue file; default: bundled Hipparcos")
    trk.add_argument("--max-rate-deg-s", type=float, default=5.0, help="the fastest the camera may turn (default 5 deg/s)")
    trk.add_argument("--no-magnitudes", action="store_true", help="ignore a magnitude column")
    trk.add_argument("--json", action="store_true", help="print JSON (one object per frame)")

    plot = gsub.add_parser("plot", help="full-sky PNG of each method's guide stars (needs matplotlib)")
    plot.add_argument("output", type=Path, nargs="?", default=Path("guide_stars.png"))
    plot.add_argument("--catalog", type=Path)
    plot.add_argument("--level", type=int, default=5)
    plot.add_argument("--cell-deg", type=float, default=5.0)
    plot.add_argument("--dpi", type=int, default=120)
    return p
