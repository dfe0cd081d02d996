"""The compiled fit-and-verify rounds (startrack._core.solver.fitted_rounds) give the Python
rounds' answer to the bit: the same verification arrays, focal length, k1 and vectors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fitted_rounds_reference import reference_rounds
from synth import synthetic_frame

from startrack.attitude import random_attitudes
from startrack.camera import Camera, RadialDistortion
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.sky import random_sky
from startrack.solver import _fov_fit
from startrack.verify import VerifyConfig, verify

_FIELDS = ("matrix", "obs_index", "cat_index", "residual_arcsec", "quaternion")


def _bits(value) -> bytes | None:
    return None if value is None else np.asarray(value).tobytes()


def _assert_same(got, want) -> None:
    """The two answers, bit for bit (a count, or verification, camera, observation)."""
    assert type(got) is type(want)
    if not isinstance(want, tuple):
        assert got == want
        return
    (check, camera, obs), (check0, camera0, obs0) = got, want
    assert (check.accepted, check.confirmed) == (check0.accepted, check0.confirmed)
    assert _bits(check.false_probability) == _bits(check0.false_probability)
    for name in _FIELDS:
        assert _bits(getattr(check, name)) == _bits(getattr(check0, name)), name
    assert camera == camera0 and _bits(camera.f_px) == _bits(camera0.f_px)
    if camera.distortion is not None:
        assert _bits(camera.distortion.k1) == _bits(camera0.distortion.k1)
    for name in ("vectors", "x", "y", "sigma_rad"):
        assert _bits(getattr(obs, name)) == _bits(getattr(obs0, name)), name
    assert obs.flux is None and obs0.flux is None
    assert check.obs_vectors is obs.vectors  # what keep_given reads the residuals from


def _both(hyp, x, y, camera, db, config, accepted=None, sigma_px=0.3):
    args = (hyp, x, y, camera, sigma_px, db, config, accepted)
    return _fov_fit._compiled_rounds(*args), reference_rounds(*args)


def _cases(true: Camera, told: Camera, seed: int, configs, frames: int = 10,
           sigma_px: float = 0.3):
    """Every answer of true hypotheses, wrong ones and held verifications on simulated
    frames of ``true`` seen through ``told``; counts by outcome."""
    db = StarDatabase(random_sky(4000, seed=seed), true.pinhole)
    rng = np.random.default_rng(seed)
    seen = {"accepted": 0, "failed": 0, "confirmed": 0, "k1": 0}
    for rot in random_attitudes(frames, rng):
        frame = synthetic_frame(db.catalog, true, rot, rng, noise_px=0.3, false_stars=2)
        x, y = frame.obs.x, frame.obs.y
        real = np.flatnonzero(frame.truth_rows >= 0)[:4]
        if len(real) < 4:
            continue
        good = Hypothesis(real, frame.truth_rows[real])
        wrong = Hypothesis(real, rng.choice(len(db.vectors), 4, replace=False))
        shifted = Hypothesis(real, np.roll(frame.truth_rows[real], 1))
        for config in configs:
            for hyp in (good, wrong, shifted):
                for n in (len(x), 16):  # the whole frame and verify_fitted's brightest
                    if hyp.obs_index.max() >= n:
                        continue
                    got, want = _both(hyp, x[:n], y[:n], told, db, config,
                                      sigma_px=sigma_px)
                    _assert_same(got, want)
                    seen["accepted" if isinstance(want, tuple) else "failed"] += 1
                    seen["confirmed"] += not isinstance(want, tuple) and want > 0
                    if isinstance(want, tuple) and want[1].distortion != told.distortion:
                        seen["k1"] += 1
            # a refit: the first verification held by the caller
            held = verify(good, Observation.from_pixels(x, y, told, sigma_px), db, config)
            got, want = _both(good, x, y, told, db, config, held, sigma_px)
            _assert_same(got, want)
    return seen


def test_the_compiled_rounds_are_the_reference_rounds_through_a_pinhole():
    true = Camera.from_fov(1024, 768, 20.0)
    told = true.with_focal(true.f_px * 1.0005)
    configs = (VerifyConfig(), VerifyConfig(match_radius_px=2.0),
               VerifyConfig(radius_sigma=3, min_radius_px=1.5, max_false_probability=1e-6),
               VerifyConfig(min_confirmed=1000))  # fails, with stars confirmed
    seen = _cases(true, told, 5, configs)
    # a pinhole's stars give no significant k1: none is fitted to their noise
    assert seen["accepted"] >= 10 and seen["confirmed"] >= 5 and seen["k1"] == 0, seen


def test_the_compiled_rounds_fit_an_undescribed_lens_as_the_reference_does():
    true = Camera.from_fov(1600, 1200, 32.0, distortion=RadialDistortion(k1=-0.06))
    told = true.pinhole.with_focal(true.f_px * 0.999)
    seen = _cases(true, told, 6, (VerifyConfig(),), sigma_px=1.0)
    assert seen["k1"] >= 3 and seen["failed"] >= 3, seen


def test_the_compiled_rounds_keep_a_described_lens_as_the_reference_does():
    lens = RadialDistortion(k1=-0.04, k2=0.01)
    true = Camera.from_fov(1280, 1024, 28.0, distortion=lens)
    told = true.with_focal(true.f_px * 1.0005)
    seen = _cases(true, told, 7, (VerifyConfig(),), frames=10)
    assert seen["accepted"] >= 3, seen


def test_an_index_verify_wraps_is_read_as_verify_reads_it():
    """A negative hypothesis index (numpy's, from the end) is one the compiled check
    refuses: ``_verify_fitted`` reads it as ``verify`` does, and answers as the
    reference rounds do; a repeated star is refused (nothing confirmed)."""
    true = Camera.from_fov(1024, 768, 20.0)
    db = StarDatabase(random_sky(4000, seed=5), true)
    rng = np.random.default_rng(5)
    frame = synthetic_frame(db.catalog, true, random_attitudes(1, rng)[0], rng, noise_px=0.3)
    real = np.flatnonzero(frame.truth_rows >= 0)[:4]
    hyp = Hypothesis(real - len(frame.obs.x), frame.truth_rows[real])
    told = true.with_focal(true.f_px * 1.0005)
    x, y = frame.obs.x, frame.obs.y
    assert _fov_fit._compiled_rounds(hyp, x, y, told, 0.3, db, VerifyConfig(), None) is None
    found = _fov_fit._verify_fitted(hyp, x, y, told, 0.3, db, VerifyConfig())
    assert isinstance(found, tuple)
    _assert_same(found, reference_rounds(hyp, x, y, told, 0.3, db, VerifyConfig()))
    twice = Hypothesis(real[[0, 0, 1, 2]], frame.truth_rows[real])
    assert _fov_fit._verify_fitted(twice, x, y, told, 0.3, db, VerifyConfig()) == 0
    assert reference_rounds(twice, x, y, told, 0.3, db, VerifyConfig()) == 0
    with pytest.raises(IndexError):  # beyond the frame, as numpy's indexing
        _fov_fit._verify_fitted(Hypothesis(real + len(x), frame.truth_rows[real]), x, y,
                                told, 0.3, db, VerifyConfig())


def test_a_held_verification_must_hold_indices_in_range():
    """A refit's held verification comes from an accepted answer: its pairs index the
    frame and the catalog (no wrapping); others are an error, not a silent answer."""
    true = Camera.from_fov(1024, 768, 20.0)
    db = StarDatabase(random_sky(4000, seed=5), true)
    rng = np.random.default_rng(5)
    frame = synthetic_frame(db.catalog, true, random_attitudes(1, rng)[0], rng, noise_px=0.3)
    real = np.flatnonzero(frame.truth_rows >= 0)[:4]
    x, y = frame.obs.x, frame.obs.y
    good = Hypothesis(real, frame.truth_rows[real])
    held = verify(good, Observation.from_pixels(x, y, true, 0.3), db, VerifyConfig())
    assert held.accepted
    wrapped = dataclasses.replace(held, obs_index=held.obs_index - len(x))
    with pytest.raises(IndexError):
        _fov_fit._verify_fitted(good, x, y, true, 0.3, db, VerifyConfig(), wrapped)


@pytest.mark.parametrize("config", [VerifyConfig(), VerifyConfig(match_radius_px=2.0),
                                    VerifyConfig(radius_sigma=3, min_radius_px=1.5)])
@pytest.mark.parametrize("lens", [None, RadialDistortion(k1=-0.04, k2=0.01), "fitted"])
def test_the_rounds_thresholds_are_the_frame_verifiers(config, lens):
    """The thresholds the compiled rounds derive from each focal length (the match
    radius, the cone, the labelling's scales) are FrameVerifier's for that camera, bit
    for bit: the rounds compute them again rather than build a Python verifier."""
    from startrack.verify import FrameVerifier

    base = Camera.from_fov(1280, 960, 24.0, cx=600.25, cy=500.5,
                           distortion=None if lens == "fitted" else lens)
    db = StarDatabase(random_sky(500, seed=1), base.pinhole)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 1280, 30), rng.uniform(0, 960, 30)
    rounds = _fov_fit.rounds_for(x, y, base, 0.7, db, config)
    for f in base.f_px * np.array([0.9, 0.999, 1.0, 1.0137, 1.2]):
        camera = base.with_focal(f)
        k1 = -0.02 if lens == "fitted" else 0.0
        if k1:
            camera = camera.with_distortion(RadialDistortion(k1=k1))
        want = FrameVerifier(Observation.from_pixels(x, y, camera, 0.7), db, config).params
        got = rounds.params_at(f, k1)
        for key in ("radius_px", "cos_radius", "cone_radius", "margin_cos"):
            assert _bits(got[key]) == _bits(want[key]), key
        for key in ("radius2", "sigma0", "resolve2", "has_flux"):
            assert _bits(got["label"][key]) == _bits(want["label"][key]), key


def test_a_focal_length_a_percent_off_is_refitted_from_the_unlabelled_matches():
    """A told focal length 1% off: the bound passes but the labelling withholds the
    stars the scale error spreads (verification UNLABELLED, never accepted, its matched
    pairs given); the rounds fit the camera to those pairs and answer with the true
    identities, as the reference rounds do."""
    true = Camera.from_fov(1024, 1024, 20.0)
    told = true.with_focal(true.f_px * 1.01)
    db = StarDatabase(random_sky(4000, seed=5), true.pinhole)
    rng = np.random.default_rng(5)
    config, recovered = VerifyConfig(), 0
    for rot in random_attitudes(40, rng):
        frame = synthetic_frame(db.catalog, true, rot, rng, noise_px=1.0, false_stars=3)
        x, y = frame.obs.x, frame.obs.y
        real = np.flatnonzero(frame.truth_rows >= 0)[:4]
        good = Hypothesis(real, frame.truth_rows[real])
        first = verify(good, Observation.from_pixels(x, y, told, 1.0), db, config)
        if not first.unlabelled:
            continue
        assert not first.accepted and first.confirmed >= config.min_confirmed
        assert first.false_probability <= config.max_false_probability
        assert len(first.obs_index) >= 3 + config.min_confirmed  # the matches it counted
        got, want = _both(good, x, y, told, db, config, sigma_px=1.0)
        _assert_same(got, want)
        check, camera, _ = got
        assert np.array_equal(frame.truth_rows[check.obs_index], check.cat_index)
        assert camera.f_px == pytest.approx(true.f_px, rel=2e-3)
        recovered += 1
    assert recovered >= 1


@pytest.mark.parametrize("distortion", [None, RadialDistortion(k1=-0.05)])
def test_a_patterns_focal_fit_on_the_rounds_is_fit_focal_bit_for_bit(distortion):
    """The quad search's guess (``pattern_focal``): the focal length fitted to a
    hypothesis' own stars from the pattern's, as :func:`fit_focal` fits them, to the bit;
    rows out of range are refused."""
    true = Camera.from_fov(1024, 768, 20.0, distortion=distortion)
    db = StarDatabase(random_sky(3000, seed=7), true.pinhole)
    rng = np.random.default_rng(7)
    frame = synthetic_frame(db.catalog, true, random_attitudes(1, rng)[0], rng, noise_px=0.3)
    x, y = frame.obs.x, frame.obs.y
    obs = np.flatnonzero(frame.truth_rows >= 0)[:4].astype(np.int64)
    rows = frame.truth_rows[obs].astype(np.int64)
    rounds = _fov_fit.rounds_for(x, y, true, 0.3, db, VerifyConfig())
    for start in true.f_px * np.array([0.97, 1.0, 1.03]):
        got = rounds.pattern_focal(obs, rows, start)
        want = _fov_fit.fit_focal(true.with_focal(start), x[obs], y[obs], db.vectors[rows])
        assert _bits(got) == _bits(want)
        assert got == pytest.approx(true.f_px, rel=5e-3)
    with pytest.raises(IndexError):
        rounds.pattern_focal(obs, rows + len(db.vectors), true.f_px)
    with pytest.raises(IndexError):
        rounds.pattern_focal(obs, rows[:3], true.f_px)


def test_a_databases_rounds_are_made_once_copied_per_frame_and_go_with_it():
    """rounds_for: one template per camera, noise and settings, held by the database (a
    blind search's evicted cut is not kept alive by it); each frame's copy has its own
    pixels, so one frame's run does not change another's."""
    import gc
    import weakref

    camera = Camera.from_fov(1024, 1024, 20.0)
    db = StarDatabase(random_sky(3000, seed=9), camera)
    rng = np.random.default_rng(9)
    frames = [synthetic_frame(db.catalog, camera, rot, rng, noise_px=0.3)
              for rot in random_attitudes(2, rng)]
    config = VerifyConfig()

    def answer(frame, database):
        real = np.flatnonzero(frame.truth_rows >= 0)[:4].astype(np.int64)
        rounds = _fov_fit.rounds_for(frame.obs.x, frame.obs.y, camera, 0.3, database, config)
        return rounds, real, frame.truth_rows[real].astype(np.int64)

    first, obs0, rows0 = answer(frames[0], db)
    alone = first.run(obs0, rows0, camera.f_px)
    second, obs1, rows1 = answer(frames[1], db)
    assert second.run(obs1, rows1, camera.f_px)[0].obs.tolist() != alone[0].obs.tolist()
    again = first.run(obs0, rows0, camera.f_px)
    assert again[0].obs.tolist() == alone[0].obs.tolist() and again[1] == alone[1]
    assert len(db.__dict__["_fitted_rounds"]) == 1  # the second frame copied the first's
    gone = weakref.ref(db)
    del db, first, second
    gc.collect()
    assert gone() is None


def test_rounds_that_do_not_settle_give_no_answer_as_the_reference_rounds(monkeypatch):
    """Past REFIT_ROUNDS a round also settles where its fit moved the camera by at most
    SETTLE_FRACTION of the match radius; rounds still unsettled after SETTLE_ROUNDS
    give no answer (their last matches were never fitted). Both rules as the reference
    has them, to the bit: with REFIT_ROUNDS at 1 (a FOV 0.2% off often needs more), the second
    rule refuses hypotheses that more rounds answer."""
    import fitted_rounds_reference

    true = Camera.from_fov(1024, 768, 20.0)
    told = true.with_focal(true.f_px * 1.002)
    seen = {}
    for settle_rounds in (1, 8):
        monkeypatch.setitem(_fov_fit._CONSTANTS, "rounds", 1)
        monkeypatch.setitem(_fov_fit._CONSTANTS, "settle_rounds", settle_rounds)
        monkeypatch.setattr(fitted_rounds_reference, "REFIT_ROUNDS", 1)
        monkeypatch.setattr(fitted_rounds_reference, "SETTLE_ROUNDS", settle_rounds)
        seen[settle_rounds] = _cases(true, told, 7, (VerifyConfig(),), frames=10)
    assert seen[8]["accepted"] > seen[1]["accepted"] > 0, seen
