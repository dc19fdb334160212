"""Three stars among false spots: named where the triangle's own sides and magnitudes pass the
false-match bound (``min_matches=3``, the default), never wrongly; ``min_matches=4`` turns it off."""

import numpy as np

import starid


def test_three_star_frames_are_named_where_the_bound_passes_and_never_wrongly() -> None:
    frames = [starid.simulate(None, 10.0, (1920, 1440), seed=s, mag_limit=6.2, noise_px=0.1, mag_noise=0.02,
                              false_stars=40) for s in range(600)]
    three = [f for f in frames if f.n_real == 3]
    assert len(three) >= 5
    kwargs = dict(fov_deg=10.0, image_size=(1920, 1440), centroid_sigma_px=0.1)
    res = starid.identify_many([f.xy for f in three], magnitudes=[f.magnitudes for f in three], **kwargs)
    named = 0
    for r, f in zip(res, three):
        ids = np.asarray(r.ids)
        assert not np.any((ids >= 0) & (ids != f.true_ids))
        if r.ok:
            named += 1
            assert r.n_matched == 3 and r.false_match_probability <= 1e-3
    assert 2 * named >= len(three)
    off = starid.identify_many([f.xy for f in three], magnitudes=[f.magnitudes for f in three], min_matches=4,
                               **kwargs)
    assert not any(r.ok for r in off)
