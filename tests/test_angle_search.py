"""The compiled angle chain search (startrack.matching.angle_search) against the Python
chain search it replaced (tests/angle_chain_reference.py): the same hypotheses in the same
order and the same diagnostics, on real-sky frames with false stars and on random
centroids (no star pattern), for every closing rule."""

from __future__ import annotations

import numpy as np
import pytest
from angle_chain_reference import reference_hypotheses
from synth import frames, prepared_matcher

from startrack.types import MatchDiagnostics, Observation


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
