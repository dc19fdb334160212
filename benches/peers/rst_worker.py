"""ruststartracker side of bench_peers.py, run in its own environment (ruststartracker needs numpy<2).

    python rst_worker.py FRAMES.npz RESULT.npz

FRAMES.npz: ``xy`` (all frames' centroids stacked, brightest first), ``start`` (offsets, one more
than frames), ``fov_deg``, ``width``, ``height``. RESULT.npz: ``ra_deg``, ``dec_deg`` (NaN where no solution),
``time_s`` per frame, ``build_s`` and ``db_bytes`` (the matcher's inputs: float32 vectors + magnitudes).
"""

from __future__ import annotations

import sys
import time

import numpy as np
import ruststartracker
from scipy.spatial.transform import Rotation


def main() -> None:
    src, dst = sys.argv[1], sys.argv[2]
    d = np.load(src)
    xy, start = d["xy"], d["start"]
    fov, width, height = float(d["fov_deg"]), int(d["width"]), int(d["height"])
    f = 0.5 * width / np.tan(np.radians(fov) / 2)
    cam = ruststartracker.CameraParameters(
        camera_matrix=np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]]),
        cam_resolution=(width, height),
        dist_coefs=None,
    )
    t0 = time.perf_counter()
    cat = ruststartracker.StarCatalog.from_hipparcos(max_magnitude=6.5)
    vecs = cat.normalized_positions(epoch=2000.0, observer_position=None)
    tracker = ruststartracker.StarTracker(vecs, cat.magnitude, cam, n_minimum_matches=5, timeout_secs=1.0)
    build = time.perf_counter() - t0
    n = len(start) - 1
    ra = np.full(n, np.nan)
    dec = np.full(n, np.nan)
    times = np.zeros(n)
    for i in range(n):
        pts = np.ascontiguousarray(xy[start[i] : start[i + 1]], dtype=np.float32)
        t = time.perf_counter()
        try:
            res = tracker.process_image_coordiantes(pts)  # (sic) the package's spelling
        except ruststartracker.StarTrackerError:
            res = None
        times[i] = time.perf_counter() - t
        if res is not None:
            # quat (x, y, z, w) maps camera vectors to the catalogue frame.
            b = Rotation.from_quat(res.quat).apply([0.0, 0.0, 1.0])
            ra[i] = np.degrees(np.arctan2(b[1], b[0])) % 360
            dec[i] = np.degrees(np.arcsin(np.clip(b[2], -1, 1)))
    np.savez(dst, ra_deg=ra, dec_deg=dec, time_s=times, build_s=build, db_bytes=vecs.nbytes + cat.magnitude.nbytes)


if __name__ == "__main__":
    main()
