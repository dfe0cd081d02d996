"""The compiled tracked attempt against verification's own decisions: the same hypotheses
accepted and rejected, the same identities, a binomial screen that agrees with scipy's,
and catalog rows that hold every star an allowed turn can bring into the image."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from startrack._core.verify.entry_points import project

from startrack.attitude import boresight_error_arcsec
from startrack.bench._tracking_bench import TrackCondition, make_sequence
from startrack.camera import Camera, RadialDistortion
from startrack.tracking._tracked_solve import (
    CatalogCone,
    Prior,
    TrackConfig,
    _attempt,
    hypotheses,
    track,
)
from startrack.verify import VerifyConfig, verify
from startrack.verify._frame import CAPTURE, camera_geometry


def _first_accepted(hyps, obs, db, config, start):
    for k in range(start, len(hyps)):
        check = verify(hyps[k], obs, db, config)
        if check.accepted:
            return k, check
    return None, None


def _run_from(obs, db, prior, config, start):
    cone = CatalogCone()
    setup = cone.setup(obs, config, TrackConfig())
    window = setup.window_px(prior.sigma_rad)
    return _attempt(obs, db, prior, cone, window, setup, start, test_prior=False)


def test_attempt_accepts_and_rejects_as_verify_does(hip_db):
    """From every starting hypothesis, the kernel's first accepted one is verify()'s first
    accepted one (with verify's default projector over the whole catalog), with the same
    identities; a prior far off has every hypothesis rejected by both."""
    cond = TrackCondition(noise_px=1.0, false_stars=25, missing=0.3)
    seq = make_sequence(hip_db.catalog, hip_db.camera, cond, 3, 10.0, seed=21)
    config = VerifyConfig()
    seen = {"accepted": 0, "rejected": 0}
    for frame in seq:
        obs = frame.obs
        near = Prior.from_rotation(frame.rotation * Rotation.from_rotvec([1e-3, -6e-4, 2e-3]),
                                   1e-3)
        off = Prior.from_rotation(frame.rotation * Rotation.from_rotvec([0.0, 0.08, 0.0]),
                                  0.01)
        for prior in (near, off):
            hyps = hypotheses(obs, hip_db, prior, config)
            for start in range(0, len(hyps), 3):
                k, ref = _first_accepted(hyps, obs, hip_db, config, start)
                got, (_, tried) = _run_from(obs, hip_db, prior, config, start)
                assert (got is None) == (ref is None)
                if ref is None:
                    assert tried == len(hyps) - start
                    seen["rejected"] += 1
                    continue
                assert tried == k - start + 1
                matrix, obs_index, cat_index = got.matrix, got.obs_index, got.rows
                assert got.hypothesis == k
                assert got.probability == pytest.approx(ref.false_probability, rel=1e-9)
                order = np.argsort(ref.obs_index)
                np.testing.assert_array_equal(obs_index, ref.obs_index[order])
                np.testing.assert_array_equal(cat_index, ref.cat_index[order])
                assert boresight_error_arcsec(Rotation.from_matrix(matrix),
                                              Rotation.from_matrix(ref.matrix)) < 0.5
                seen["accepted"] += 1
    assert seen["accepted"] >= 6 and seen["rejected"] >= 6


@pytest.mark.parametrize("distortion", [None, RadialDistortion(k1=-0.3, k2=0.05)])
def test_cone_holds_every_star_an_allowed_turn_brings_in(hip_db, distortion):
    camera = Camera.from_fov(1024, 768, 20.0, distortion=distortion)
    rng = np.random.default_rng(3)
    radius = 2.0
    vectors = np.ascontiguousarray(hip_db.vectors)
    for trial in range(6):
        prior = Rotation.random(random_state=rng).as_matrix()
        turn = [0.002, 0.02, 0.1][trial % 3]
        cone = CatalogCone()
        cone.look_up(hip_db, camera, np.ascontiguousarray(prior), turn, radius)
        held = set(cone.rows.tolist())
        assert cone.turn > turn and len(held) < len(vectors)
        for _ in range(40):
            axis = rng.normal(size=3)
            w = axis / np.linalg.norm(axis) * cone.turn * rng.uniform(0.5, 1.0)
            at = np.ascontiguousarray(prior @ Rotation.from_rotvec(w).as_matrix())
            _, _, inside = project(vectors, at, camera_geometry(camera), CAPTURE * radius)
            assert set(np.flatnonzero(inside).tolist()) <= held


def test_cone_is_reused_while_the_prediction_stays_inside(hip_db):
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 8, 10.0, seed=5)
    cone, config = CatalogCone(), VerifyConfig()
    rows_seen = []
    for frame in seq:
        prior = Prior.from_rotation(frame.rotation, 5e-5)
        assert track(frame.obs, hip_db, prior, config, cone=cone).solved
        rows_seen.append(id(cone.rows))
    # 0.23 deg a frame against a 1 deg spare turn: a fresh lookup every few frames only.
    assert 1 < len(set(rows_seen)) <= 4
    # A prediction 10 deg away is not covered: the rows are looked up again.
    far = Prior.from_rotation(seq[0].rotation * Rotation.from_rotvec([math.radians(10), 0, 0]),
                              5e-5)
    before = id(cone.rows)
    track(seq[0].obs, hip_db, far, config, cone=cone)
    assert id(cone.rows) != before
