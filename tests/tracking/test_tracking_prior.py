"""The prediction tested as its own hypothesis (startrack._core.tracking.tracked_frame): its
bound is
verification's binomial tail, a true prediction is accepted with the true identities, a
wrong one or a frame of no stars is never accepted, and a window too wide for the test
leaves the frame to the three-star hypotheses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import binom
from startrack._core.tracking.tracked_frame import ACCEPTED, NONE, attempt_at_prior, prior_bound

from startrack.attitude import boresight_error_arcsec
from startrack.bench._tracking_bench import TrackCondition, make_sequence
from startrack.match_records import Observation
from startrack.solver._lost_in_space import residuals_arcsec
from startrack.tracking._tracked_solve import CatalogCone, Prior, TrackConfig, track, track_frame
from startrack.verify import VerifyConfig


def _prior_attempt(obs, db, prior):
    """attempt_at_prior on ``obs`` near ``prior``, its rows looked up for it (an
    :class:`startrack._core.tracking.tracked_frame.Attempt`)."""
    cone = CatalogCone()
    setup = cone.setup(obs, VerifyConfig(), TrackConfig())
    window = setup.window_px(prior.sigma_rad)
    cone.look_up(db, obs.camera, prior.matrix, setup.turn(window), setup.radius_px)
    return attempt_at_prior(cone.held, track_frame(obs, setup), prior.matrix,
                            prior.sigma_rad, setup)


@pytest.mark.parametrize("matched,n_obs,n_in,window", [
    (5, 5, 40, 3.0), (12, 80, 100, 9.0), (30, 90, 110, 6.0), (3, 60, 200, 20.0),
    (60, 60, 120, 2.0), (8, 200, 300, 40.0)])
def test_prior_bound_is_the_binomial_tail(matched, n_obs, n_in, window):
    area = math.pi / (1024 * 1024)
    p = min(1.0, n_in * window * window * area)
    expected = binom.sf(matched - 1, n_obs, p)  # P(at least ``matched`` by chance)
    assert prior_bound(matched, n_obs, n_in, window, area) == pytest.approx(
        expected, rel=1e-9, abs=1e-300)


def test_a_true_prediction_is_accepted_with_the_true_identities(hip_db):
    cond = TrackCondition(noise_px=0.5, false_stars=5, missing=0.2)
    seq = make_sequence(hip_db.catalog, hip_db.camera, cond, 6, 10.0, seed=11)
    for frame in seq:
        # A prediction 2 px off with a 1 px sigma, as a tracked sequence gives.
        off = Rotation.from_rotvec([4e-4, -5e-4, 3e-4])
        prior = Prior.from_rotation(frame.rotation * off, 1.0 / hip_db.camera.f_px)
        found = _prior_attempt(frame.obs, hip_db, prior)
        obs_i, rows, matrix, resid, quat = (found.obs_index, found.rows, found.matrix,
                                            found.residuals, found.quaternion)
        assert found.status == ACCEPTED
        assert found.probability <= VerifyConfig().max_false_probability
        assert len(obs_i) >= 0.8 * (frame.truth_rows >= 0).sum()
        np.testing.assert_array_equal(rows, frame.truth_rows[obs_i])
        error = boresight_error_arcsec(Rotation.from_matrix(matrix), frame.rotation)
        assert error < 10.0
        # The residuals and quaternion come from the kernel, as verification's one-call
        # path gives them.
        np.testing.assert_allclose(resid, residuals_arcsec(matrix, frame.obs, obs_i,
                                                           hip_db.vectors[rows]), rtol=1e-12)
        np.testing.assert_allclose(Rotation.from_quat(quat).as_matrix(), matrix, atol=1e-12)
        solution = track(frame.obs, hip_db, prior)
        assert solution.solved and solution.diagnostics.hypotheses == 1
        np.testing.assert_array_equal(solution.cat_index, frame.truth_rows[solution.obs_index])


@pytest.mark.parametrize("turn_deg", [0.3, 2.0, 10.0])
def test_a_wrong_prediction_is_not_accepted(hip_db, turn_deg):
    cond = TrackCondition(noise_px=0.5, false_stars=2, missing=0.1)
    seq = make_sequence(hip_db.catalog, hip_db.camera, cond, 4, 10.0, seed=12)
    rng = np.random.default_rng(7)
    for frame in seq:
        axis = rng.normal(size=3)
        axis *= math.radians(turn_deg) / np.linalg.norm(axis)
        prior = Prior.from_rotation(frame.rotation * Rotation.from_rotvec(axis),
                                    1.5 / hip_db.camera.f_px)
        assert _prior_attempt(frame.obs, hip_db, prior).status != ACCEPTED


def test_random_points_are_never_accepted(hip_db):
    """Frames of points at random, 5 to 80 of them, near a prediction anywhere on the sky:
    the prediction is never accepted (the bound is 1e-9 a frame), nor is the frame."""
    camera = hip_db.camera
    rng = np.random.default_rng(13)
    accepted = 0
    for _ in range(300):
        n = int(rng.integers(5, 81))
        x, y = rng.uniform(0, camera.width, n), rng.uniform(0, camera.height, n)
        obs = Observation.from_pixels(x, y, camera, 0.5)
        prior = Prior.from_rotation(Rotation.random(random_state=rng),
                                    rng.uniform(0.3, 3.0) / camera.f_px)
        accepted += _prior_attempt(obs, hip_db, prior).status == ACCEPTED
    assert accepted == 0


def test_a_window_too_wide_for_the_test_leaves_it_to_the_hypotheses(hip_db):
    """After frames unsolved the prediction is loose: its window holds a catalog star for
    nearly any point, so the bound refuses it, and the vote's three-star hypotheses solve
    the frame."""
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 2, 10.0, seed=14)
    frame = seq[1]
    prior = Prior.from_rotation(frame.rotation * Rotation.from_rotvec([2e-3, 0.0, 1e-3]),
                                8e-3)
    found = _prior_attempt(frame.obs, hip_db, prior)
    assert found.status == NONE and found.probability > VerifyConfig().max_false_probability
    solution = track(frame.obs, hip_db, prior)
    assert solution.solved and solution.diagnostics.hypotheses > 1
    np.testing.assert_array_equal(solution.cat_index, frame.truth_rows[solution.obs_index])
