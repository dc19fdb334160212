"""A field of view is an estimate: given a few percent off it still identifies, with the field
found; given beyond its tolerance it costs the solution, never a wrong id."""

from __future__ import annotations

import numpy as np
import pytest

import starid


def _frames(n: int = 8) -> list[starid.Frame]:
    frames = [starid.simulate(fov_deg=12.0, image_size=(512, 512), seed=40 + s, noise_px=0.2, mag_noise=0.1) for s in range(n)]
    return [f for f in frames if f.n_real >= 8]


@pytest.mark.parametrize("off", [-0.07, 0.04, 0.09])
def test_a_field_given_within_its_tolerance_is_found(off: float) -> None:
    for f in _frames():
        res = starid.identify(f.xy, fov_deg=12.0 * (1 + off), image_size=(512, 512), magnitudes=f.magnitudes)
        assert res.ok
        named = res.ids >= 0
        assert (res.ids[named] == f.true_ids[named]).all()
        assert abs(res.fov_deg / 12.0 - 1) < 2e-3 and np.isfinite(res.focal_sigma_px)


def test_a_field_beyond_its_tolerance_costs_the_solution_not_a_wrong_id() -> None:
    for off in (-0.2, 0.2):
        for f in _frames(4):
            res = starid.identify(f.xy, fov_deg=12.0 * (1 + off), image_size=(512, 512), magnitudes=f.magnitudes)
            named = res.ids >= 0
            assert (res.ids[named] == f.true_ids[named]).all()


def test_an_exact_field_is_a_setting() -> None:
    f = _frames(1)[0]
    held = starid.identify(f.xy, fov_deg=12.0 * 1.08, image_size=(512, 512), magnitudes=f.magnitudes, fov_tolerance=0.0)
    assert not held.ok
    assert starid.IdentifyConfig().fov_tolerance == 0.1
    assert starid.IdentifyConfig(fov_tolerance=0.2).to_dict()["fov_tolerance"] == 0.2
    with pytest.raises(starid.InvalidInputError, match="fov_tolerance"):
        starid.IdentifyConfig(fov_tolerance=0.6)
