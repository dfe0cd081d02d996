"""The compiled angle chain search (startrack._core.matchers.angle) against the Python
chain search it replaced (tests/matchers/angle_chain_reference.py): the same hypotheses in the same
order and the same diagnostics, on real-sky frames with false stars and on random
centroids (no star pattern), for every closing rule; and its screen (verification's
first test inside the search) drops exactly what verification refuses there."""

from __future__ import annotations

import numpy as np
import pytest
from angle_chain_reference import reference_hypotheses
from synth import frames, prepared_matcher

from startrack.match_records import MatchDiagnostics, Observation
from startrack.solver import identify
from startrack.verify import VerifyConfig, verify


def _junk(camera, n_sets: int, seed: int) -> list[Observation]:
    rng = np.random.default_rng(seed)
    return [Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                    rng.uniform(0, camera.height - 1, n), camera, 1.0)
            for n in rng.integers(4, 40, n_sets)]


def _same(matcher, obs: Observation) -> None:
    d_new, d_ref = MatchDiagnostics(), MatchDiagnostics()
    new = list(matcher.hypotheses(obs, d_new))
    ref = list(reference_hypotheses(matcher, obs, d_ref))
    assert len(new) == len(ref)
    for a, b in zip(new, ref, strict=True):
        assert np.array_equal(a.obs_index, b.obs_index)
        assert np.array_equal(a.cat_index, b.cat_index)
    assert (d_new.pivots, d_new.candidates) == (d_ref.pivots, d_ref.candidates)
    assert list(d_new.extra.items()) == list(d_ref.extra.items())


@pytest.mark.parametrize("method", ["angle", "angle_closed", "angle_open"])
def test_same_hypotheses_as_the_python_search(hip_db, method):
    matcher = prepared_matcher(method, hip_db)
    sky = list(frames(hip_db.catalog, hip_db.camera, 6, seed=5, noise_px=1.0,
                      false_stars=4, missing=0.2))
    assert sky
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 4, seed=9):
        _same(matcher, obs)


def test_small_store_and_budget_give_the_same_hypotheses(hip_db):
    """A tight lookup budget ends chains mid-pivot, where the kept counts must replay."""
    matcher = prepared_matcher("angle", hip_db, max_lookups=37, max_ambiguous=1)
    for obs in _junk(hip_db.camera, 3, seed=4):
        _same(matcher, obs)


@pytest.mark.parametrize("method", ["angle", "angle_open"])
def test_the_screen_drops_exactly_what_verification_refuses_first(hip_db, method):
    """With verification's first-test radius the search hands over the hypotheses of the
    unscreened search that the test passes, in the same order, and drops only those that
    verify() refuses at that test; its pivots and lookups are the same."""
    # every ordering: the paper's one chain leaves too few answers to screen
    matcher = prepared_matcher(method, hip_db, max_chains=220)
    config = VerifyConfig()
    sky = list(frames(hip_db.catalog, hip_db.camera, 4, seed=8, noise_px=1.0,
                      false_stars=6, missing=0.2))
    dropped = 0
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 6, seed=12):
        radius = config.radius_px(obs) / obs.camera.f_px
        d_all, d_screened = MatchDiagnostics(), MatchDiagnostics()
        every = list(matcher.hypotheses(obs, d_all))
        screened = list(matcher.hypotheses(obs, d_screened, radius))
        refused = [verify(h, obs, hip_db, config).matrix is None for h in every]
        kept = [h for h, r in zip(every, refused, strict=True) if not r]
        assert len(screened) == len(kept)
        for a, b in zip(screened, kept, strict=True):
            assert np.array_equal(a.obs_index, b.obs_index)
            assert np.array_equal(a.cat_index, b.cat_index)
        assert (d_screened.pivots, d_screened.candidates) == (d_all.pivots, d_all.candidates)
        dropped += sum(refused)
    assert dropped > 20  # the junk sets' answers are nearly all refused at the first test


def test_the_screen_leaves_every_answer_identify_gives(hip_db):
    """identify() (which screens) solves the frames the same as without the screen."""
    matcher = prepared_matcher("angle", hip_db)
    unscreened = _Unscreened(matcher)
    sky = list(frames(hip_db.catalog, hip_db.camera, 6, seed=3, noise_px=1.0,
                      false_stars=5, missing=0.2))
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 4, seed=2):
        a, b = identify(obs, matcher), identify(obs, unscreened)
        assert a.solved == b.solved
        np.testing.assert_array_equal(a.obs_index, b.obs_index)
        np.testing.assert_array_equal(a.cat_index, b.cat_index)
        assert a.diagnostics.hypotheses <= b.diagnostics.hypotheses


class _Unscreened:
    """A matcher that ignores the screen it is offered."""

    def __init__(self, matcher) -> None:
        self._matcher = matcher

    def __getattr__(self, name: str):
        return getattr(self._matcher, name)

    def hypotheses(self, obs, diag, screen_rad=None):
        return self._matcher.hypotheses(obs, diag)
