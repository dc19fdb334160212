"""Property tests: identification never reports a wrong id, whatever the attitude or handedness."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

import starid


@given(
    ra=st.floats(0, 360),
    dec=st.floats(-89.9, 89.9),
    roll=st.floats(0, 360),
    mirrored=st.booleans(),
    noise=st.floats(0, 0.5),
    false_stars=st.integers(0, 3),
)
def test_never_wrong(ra: float, dec: float, roll: float, mirrored: bool, noise: float, false_stars: int) -> None:
    f = starid.simulate(
        fov_deg=12.0, image_size=(512, 512), attitude_deg=(ra, dec, roll), seed=7,
        noise_px=noise, false_stars=false_stars, mirrored=mirrored,
    )
    assume(len(f.xy) >= 4)
    res = starid.identify(f.xy, fov_deg=12.0, image_size=(512, 512), brightness_order=False)
    known = res.ids >= 0
    assert np.array_equal(res.ids[known], f.true_ids[known])
    if f.n_real >= 6:
        assert res.ok and res.mirrored == mirrored
        assert abs(res.dec_deg - dec) < 0.01


@given(st.lists(st.tuples(st.floats(0, 512), st.floats(0, 512)), min_size=4, max_size=12, unique=True))
def test_random_points_are_not_stars(points: list[tuple[float, float]]) -> None:
    res = starid.identify(np.array(points), fov_deg=12.0, image_size=(512, 512))
    assert not res.ok and (res.ids == -1).all()
