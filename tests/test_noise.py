"""The centroid noise is a hypothesis: ``identify_many`` learns it from its frames identified with
a wide margin and searches its failed frames again with it; a stated noise the residuals refuse
costs identifications, never a wrong id; every result says which noise it used and why."""

import json
import pickle

import numpy as np
import pytest

import starid


def kelvins_like(seeds: range, noise_px: float) -> list[starid.Frame]:
    """10 degree, 1920x1440 frames of stars to 6.2 among 40 false spots."""
    return [starid.simulate(None, 10.0, (1920, 1440), seed=s, mag_limit=6.2, noise_px=noise_px, mag_noise=0.02,
                            false_stars=40) for s in seeds]


def wrong_ids(res: starid.Identification, frame: starid.Frame) -> int:
    ids = np.asarray(res.ids)
    return int(np.sum((ids >= 0) & (ids != frame.true_ids)))


def test_a_batch_learns_the_noise_and_names_a_four_star_frame_with_it() -> None:
    frames = kelvins_like(range(100, 140), 0.1)
    kwargs = dict(fov_deg=10.0, image_size=(1920, 1440), magnitudes=[f.magnitudes for f in frames])
    alone = starid.identify_many([f.xy for f in frames], learn_noise=False, **kwargs)
    res = starid.identify_many([f.xy for f in frames], **kwargs)
    learned = [i for i, r in enumerate(res) if r.learned_sigma_px is not None]
    assert learned, "no frame was searched again with a learned noise"
    for i in learned:
        assert res[i].ok and not alone[i].ok
        assert res[i].noise_source == "learned"
        assert res[i].learned_sigma_px == pytest.approx(0.1, rel=0.2)
        assert res[i].noise_step_px == res[i].learned_sigma_px
    assert {r.noise_source for i, r in enumerate(res) if r.ok and i not in learned} == {"ladder"}
    assert sum(wrong_ids(r, f) for r, f in zip(res, frames)) == 0
    back = pickle.loads(pickle.dumps(res[learned[0]]))
    assert (back.noise_source, back.learned_sigma_px, back.noise_step_px) == (
        "learned", res[learned[0]].learned_sigma_px, res[learned[0]].noise_step_px)
    d = res[learned[0]].to_dict()
    assert d["noise_source"] == "learned" and json.dumps(d)


@pytest.mark.parametrize("factor", [0.25, 4.0])
def test_a_noise_stated_four_times_off_never_names_a_spot_wrong(factor: float) -> None:
    frames = kelvins_like(range(40), 0.2)
    stated = 0.2 * factor
    res = starid.identify_many([f.xy for f in frames], fov_deg=10.0, image_size=(1920, 1440),
                               magnitudes=[f.magnitudes for f in frames], centroid_sigma_px=stated)
    assert sum(wrong_ids(r, f) for r, f in zip(res, frames)) == 0
    ok = [r for r in res if r.ok]
    assert len(ok) >= 30
    assert {r.noise_source for r in res if not r.ok} <= {"none"}
    if factor > 1:
        # Stated too large: named at a tighter step of the default ladder, or borne out with the
        # matches judged at the noise measured.
        assert {r.noise_source for r in ok} <= {"stated", "narrowed"}
        assert np.median([r.centroid_sigma_px for r in ok]) < 0.5 * stated
    else:
        # Stated too small: some frames refuse it for a looser step.
        assert "widened" in {r.noise_source for r in ok} or all(r.centroid_sigma_px > stated for r in ok)


def test_the_noise_settings_are_settings() -> None:
    config = starid.IdentifyConfig(learn_noise=False, noise_fallback=False)
    assert not config.learn_noise and not config.noise_fallback
    assert starid.IdentifyConfig().learn_noise and starid.IdentifyConfig().noise_fallback
    assert "learn_noise" in starid.IdentifyConfig.names()
    assert config.replace(learn_noise=True).learn_noise
