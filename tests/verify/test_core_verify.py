"""The one compiled verification (startrack._core.verify.entry_points): scipy's binomial tail,
scipy's
Rotation and numpy's indexing rules for odd hypotheses (it was held to the numba kernels
it replaced, to the bit, before they were deleted)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import bdtrc
from startrack._core.verify.entry_points import NOT_ACCEPTED, binomial_tail
from synth import synthetic_frame

from startrack._core import shared
from startrack.attitude import random_attitudes
from startrack.camera import Camera, RadialDistortion
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.sky import random_sky
from startrack.verify._frame import FrameVerifier, camera_geometry
from startrack.verify._verification import VerifyConfig, rotation_of, verify

CONFIG = VerifyConfig()


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=3), Camera.from_fov(1024, 1024, 17.5))


def test_binomial_tail_agrees_with_scipy():
    """Over the counts and densities verification meets, within 1e-12 relative, and 0
    exactly where scipy's underflows."""
    worst, checked = 0.0, 0
    for n in (*range(1, 61), 80, 120, 200, 300):
        for p in (*np.logspace(-7, -0.3, 25), 0.9):
            for k in range(-1, n + 1):
                ref, got = bdtrc(k, n, p), binomial_tail(k, n, p)
                if ref == 0.0 or got == 0.0:
                    assert ref == got or max(ref, got) < 1e-290, (k, n, p, ref, got)
                    continue
                worst = max(worst, abs(got - ref) / ref)
                checked += 1
    assert checked > 10000
    assert worst <= 1e-12


def test_binomial_tail_edges():
    assert binomial_tail(-1, 10, 0.1) == 1.0
    assert binomial_tail(10, 10, 0.1) == 0.0
    assert binomial_tail(3, 10, 0.0) == 0.0
    assert binomial_tail(3, 10, 1.0) == 1.0
    tail = [binomial_tail(k, 40, 1e-3) for k in range(40)]
    assert all(a > b for a, b in zip(tail, tail[1:], strict=False) if b > 0.0)


def _cases(db, rng, n_frames, fixed):
    """(hypothesis, observation, fixed rows or None): right, partial, swapped and random
    hypotheses, and frames cut to four stars (too few confirmations)."""
    for rot in random_attitudes(n_frames, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, noise_px=0.5, false_stars=3)
        obs, truth = frame.obs, frame.truth_rows
        obs = Observation.from_pixels(obs.x, obs.y, obs.camera, 0.5,
                                      rng.uniform(1e3, 1e5, len(obs)))
        real = np.flatnonzero(truth >= 0)
        if len(real) < 6:
            continue
        rows = db.cone(rot.as_matrix()[:, 2], np.radians(14.0)) if fixed else None
        few = Observation(obs.vectors[real[:4]], obs.x[real[:4]], obs.y[real[:4]],
                          obs.camera, obs.sigma_rad)
        yield Hypothesis(np.arange(3), truth[real[:3]]), few, rows
        for idx in (real[:3], real[:4], real[2:5]):
            yield Hypothesis(idx, truth[idx]), obs, rows
        yield Hypothesis(real[:3], truth[real[[1, 0, 2]]]), obs, rows
        yield Hypothesis(real[:3], rng.choice(len(db.vectors), 3, replace=False)), obs, rows


@pytest.mark.parametrize("fixed", [False, True])
def test_verification_reports_its_attitude_as_from_quat(random_db, fixed):
    """An accepted attitude's Rotation is scipy's from_quat of its quaternion, and its
    residuals are the angles between the labelled stars and their catalog stars."""
    rng = np.random.default_rng(21)
    accepted = refused = 0
    for hyp, obs, rows in _cases(random_db, rng, 8, fixed):
        checker = FrameVerifier(obs, random_db, CONFIG, rows)
        got = verify(hyp, obs, random_db, CONFIG, checker)
        if not got.accepted:
            refused += 1
            continue
        accepted += 1
        ref = Rotation.from_quat(shared.matrix_to_quaternion(got.matrix))
        np.testing.assert_array_equal(got.rotation.as_quat(canonical=False),
                                      ref.as_quat(canonical=False))
        sky = obs.vectors[got.obs_index] @ got.matrix.T
        dots = np.clip(np.sum(sky * random_db.vectors[got.cat_index], axis=1), -1, 1)
        np.testing.assert_allclose(got.residual_arcsec, np.degrees(np.arccos(dots)) * 3600,
                                   atol=1e-3)
    assert accepted >= 10 and refused >= 5


def test_rotation_of_is_from_quat():
    rng = np.random.default_rng(5)
    for rot in random_attitudes(50, rng):
        matrix = np.ascontiguousarray(rot.as_matrix())
        np.testing.assert_array_equal(rotation_of(matrix).as_matrix(), Rotation.from_quat(
            shared.matrix_to_quaternion(matrix)).as_matrix())


def test_unusual_hypotheses_follow_numpys_indexing(random_db):
    """Repeated stars are refused, an index beyond the frame or the catalog raises
    numpy's IndexError, and a negative one counts from the end."""
    rng = np.random.default_rng(2)
    frame = synthetic_frame(random_db.catalog, random_db.camera,
                            random_attitudes(1, rng)[0], rng, noise_px=0.3)
    obs, t = frame.obs, frame.truth_rows
    assert not verify(Hypothesis(np.array([0, 1, 1]), t[:3]), obs, random_db,
                      CONFIG).accepted
    with pytest.raises(IndexError):
        verify(Hypothesis(np.arange(3), np.array([t[0], t[1], 10**7])), obs, random_db, CONFIG)
    with pytest.raises(IndexError):
        verify(Hypothesis(np.array([0, 1, len(obs)]), t[:3]), obs, random_db, CONFIG)
    n = len(obs)
    plain = verify(Hypothesis(np.array([n - 3, n - 2, n - 1]), t[n - 3:]), obs, random_db,
                   CONFIG)
    negative = verify(Hypothesis(np.array([-3, -2, -1]), t[n - 3:]), obs, random_db, CONFIG)
    assert plain.accepted == negative.accepted
    np.testing.assert_array_equal(plain.obs_index, negative.obs_index)


def test_too_few_confirmations_are_not_accepted_with_their_bound(random_db):
    rng = np.random.default_rng(8)
    seen = 0
    for hyp, obs, _ in _cases(random_db, rng, 6, False):
        if len(obs) != 4:
            continue
        verdict = FrameVerifier(obs, random_db, CONFIG).check(
            np.asarray(hyp.obs_index, np.int64), np.asarray(hyp.cat_index, np.int64))
        assert verdict.status == NOT_ACCEPTED and verdict.confirmed <= 1
        seen += 1
    assert seen >= 3


def test_angle_table_is_numpys_arccos():
    from startrack.matchers import angle_table

    rng = np.random.default_rng(9)
    a = rng.normal(size=(40, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    a[1] = a[0]  # a dot product that rounds beyond 1 is clipped, not NaN
    want = np.arccos(np.clip(a @ a[:7].T, -1.0, 1.0))
    # near 0 an ulp of the dot product is 1e-8 rad of angle
    np.testing.assert_allclose(angle_table(a, a[:7]), want, rtol=0, atol=1e-7)
    assert np.all(np.isfinite(angle_table(a)))


@pytest.mark.parametrize("distortion", [None, RadialDistortion(k1=-0.05, k2=0.01, k3=-0.002)])
def test_camera_geometry_is_the_cameras_fields(distortion):
    cam = Camera.from_fov(1001, 640, 15.0, cx=499.75, cy=321.0, distortion=distortion)
    d = distortion or RadialDistortion()
    assert camera_geometry(cam) == {
        "f_px": cam.f_px, "cx": 499.75, "cy": 321.0, "width": 1001.0, "height": 640.0,
        "k1": d.k1, "k2": d.k2, "k3": d.k3, "max_r2": d.max_r2}


def test_frames_sharing_the_threads_buffers_keep_their_answers(random_db):
    """Checks of several frames interleaved (their matching buffers are the thread's)
    give each frame's answers, and an answer already given is not written over."""
    rng = np.random.default_rng(23)
    cases = list(_cases(random_db, rng, 4, False))
    alone = [verify(hyp, obs, random_db, CONFIG) for hyp, obs, _ in cases]
    kept = [(v.obs_index.copy(), v.cat_index.copy()) for v in alone]
    checkers = {id(obs): FrameVerifier(obs, random_db, CONFIG) for _, obs, _ in cases}
    for (hyp, obs, _), want in zip(reversed(cases), reversed(alone), strict=True):
        got = verify(hyp, obs, random_db, CONFIG, checkers[id(obs)])
        assert got.accepted == want.accepted and got.confirmed == want.confirmed
        np.testing.assert_array_equal(got.obs_index, want.obs_index)
        np.testing.assert_array_equal(got.cat_index, want.cat_index)
    for v, (obs_index, cat_index) in zip(alone, kept, strict=True):
        np.testing.assert_array_equal(v.obs_index, obs_index)
        np.testing.assert_array_equal(v.cat_index, cat_index)
    assert sum(v.accepted for v in alone) >= 4


@pytest.mark.parametrize("radius", [0.0, 2.0, 7.5, 40.0, np.inf])
def test_matching_on_the_frames_grid_is_the_nearest_pairing(radius):
    """A frame's matching (its observed stars bucketed once, each projected star claiming
    the observed stars near it) pairs exactly as the nearest pairing of the projected
    stars in the widened image: ties, repeated stars, stars outside the image and NaN
    positions included."""
    from startrack._core.verify.entry_points import Frame, match, project
    from startrack._core.verify.nearest import matches as nearest_matches

    camera = Camera.from_fov(640, 480, 20.0)
    geometry = camera_geometry(camera)
    rng = np.random.default_rng(int(min(radius, 99.0) * 10) + 5)
    vectors = rng.normal(size=(300, 3)) * [0.12, 0.09, 1.0]
    vectors[3], vectors[11] = vectors[2], vectors[10]  # catalog stars twice: ties
    vectors /= np.linalg.norm(vectors, axis=1)[:, None]
    matrix = Rotation.from_rotvec([0.01, -0.02, 0.3]).as_matrix()
    sky = np.ascontiguousarray(vectors @ matrix.T)
    x, y, seen = project(sky, matrix, geometry, 0.0)
    x, y = x[seen][:60], y[seen][:60]
    ox = np.concatenate([x + rng.normal(0, 2.0, 60), rng.uniform(-30, 670, 30)])
    oy = np.concatenate([y + rng.normal(0, 2.0, 60), rng.uniform(-30, 510, 30)])
    ox[61], oy[61] = ox[60], oy[60]  # an observed star twice
    ox[5], oy[7] = np.nan, np.nan
    frame = Frame(np.zeros((len(ox), 3)), ox, oy, np.ones(len(ox)), geometry)
    obs, pos, n_in = match(frame, sky, matrix, radius)
    x, y, inside = project(sky, matrix, geometry, radius)
    where = np.flatnonzero(inside)
    want_obs, want_at = nearest_matches(ox, oy, x[where], y[where], radius)
    np.testing.assert_array_equal(obs, want_obs)
    np.testing.assert_array_equal(pos, where[want_at])
    assert n_in == len(where) and (len(obs) > 15 or radius == 0.0)
