"""Make the bundled example frame ``python/starid/data/example_frame.csv``.

A 12 deg x 12 deg, 512 x 512 px frame of Orion's belt from the bundled catalogue (stars to Hp 6.0): 0.2 px
centroid noise, 0.1 mag magnitude noise and two false stars. Re-running gives the same file.

    python catalog/make_example_frame.py
"""

from pathlib import Path

from starid.cli import main

ROOT = Path(__file__).resolve().parent.parent

if __name__ == "__main__":
    main([
        "simulate", str(ROOT / "python" / "starid" / "data" / "example_frame.csv"),
        "--fov-deg", "12", "--size", "512x512", "--seed", "2019",
        "--attitude-deg", "83.0", "-1.0", "20.0",
        "--mag-limit", "6.0", "--noise-px", "0.2", "--mag-noise", "0.1", "--false-stars", "2",
    ])
