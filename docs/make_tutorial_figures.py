"""Make the tutorial's two figures from a sky photograph.

    python docs/make_tutorial_figures.py PHOTO.jpg FOV_DEG [--out docs]

Writes ``tutorial-annotated.png`` (the photograph with its spots circled and named, by
``starid.plot.annotate``) and ``tutorial-wcs.png`` (the photograph under the solution's WCS, with an RA/Dec grid drawn
by astropy). Needs the plot and fits extras: ``pip install "starid-solver[plot,fits]"``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import starid  # noqa: E402
import starid.plot  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("photo", type=Path)
    ap.add_argument("fov_deg", type=float, help="the field of view across the width, roughly (within 10 %%)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--width-px", type=int, default=900, help="width of each figure in pixels")
    args = ap.parse_args()
    res = starid.identify_image(args.photo, None, args.fov_deg)
    ident = res.identification
    print(f"{args.photo.name}: {ident.status}, {ident.n_matched} of {len(ident.ids)} spots named, "
          f"RA {ident.ra_deg:.4f} Dec {ident.dec_deg:+.4f} roll {ident.roll_deg:.3f}, field {ident.fov_deg:.3f} deg")
    img = starid.read_image(args.photo)
    h, w = img.shape
    dpi = 100 * w / args.width_px
    starid.plot.annotate(args.photo, res, args.out / "tutorial-annotated.png", dpi=int(round(dpi)))
    wcs = res.wcs()
    fig = plt.figure(figsize=(args.width_px / 100, args.width_px / 100 * h / w), dpi=100)
    ax = fig.add_subplot(projection=wcs)
    lo, hi = np.percentile(img, [1, 99.7])
    ax.imshow(img, cmap="gray", vmin=lo, vmax=hi, origin="lower")
    ax.invert_yaxis()  # the first row on top, as the photograph is seen
    ax.coords.grid(color="#ffd33d", alpha=0.6, linestyle="solid", linewidth=0.6)
    ax.coords[0].set_axislabel("RA")
    ax.coords[1].set_axislabel("Dec")
    ax.set_title(f"starid solution: RA {ident.ra_deg:.3f}°, Dec {ident.dec_deg:+.3f}°, field {ident.fov_deg:.2f}°")
    fig.savefig(args.out / "tutorial-wcs.png", dpi=100, bbox_inches="tight")
    print(f"wrote {args.out / 'tutorial-annotated.png'} and {args.out / 'tutorial-wcs.png'}")


if __name__ == "__main__":
    main()
