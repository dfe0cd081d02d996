"""Tracking: trajectory maths, the tracking stage's verification against verify's, and
sequences solved from centroids (tracking, fallback after a jump, no wrong attitudes)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from startrack._core.tracking.prediction import rotation_exp as _exp
from startrack._core.tracking.prediction import rotation_log as _log
from waiting import run_python

from startrack.attitude import boresight_error_arcsec, random_attitudes
from startrack.bench._tracking_bench import TrackCondition, make_sequence
from startrack.errors import InputError
from startrack.matchers import get_matcher
from startrack.simulate._trajectory import constant_rate, profile_trajectory, read_profile
from startrack.solver import identify
from startrack.tracking._lock_state import Tracker
from startrack.tracking._tracked_solve import Prior, track
from startrack.verify import VerifyConfig


def test_constant_rate_is_r0_times_exp_of_body_rate():
    r0 = random_attitudes(1, np.random.default_rng(0))[0]
    rate = np.array([1.0, 0.5, 2.0])
    traj = constant_rate(r0, rate, 10.0, 30)
    assert len(traj) == 30 and np.allclose(traj.times, np.arange(30) / 10.0)
    assert (traj.rotations[0].inv() * r0).magnitude() < 1e-12
    # Frame to frame the attitude turns by w / F about camera-frame axes (right-multiplied).
    steps = (traj.rotations[:-1].inv() * traj.rotations[1:]).as_rotvec()
    assert np.allclose(steps, np.radians(rate) / 10.0, atol=1e-12)
    k = 17
    expected = r0 * Rotation.from_rotvec(np.radians(rate) * k / 10.0)
    assert (traj.rotations[k].inv() * expected).magnitude() < 1e-12
    assert np.allclose(traj.rates_dps, rate)


def test_exp_log_match_scipy():
    rng = np.random.default_rng(1)
    for v in rng.normal(0, 0.3, (20, 3)):
        assert np.allclose(_exp(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-12)
        assert np.allclose(_log(Rotation.from_rotvec(v).as_matrix()), v, atol=1e-9)


def test_prediction_carries_the_rate_forward_with_a_growing_sigma():
    """From two attitudes ``gap`` frames apart the next is predicted by their per-frame
    rotation (scipy's composition), its sigma growing per frame by the rate's error."""
    from startrack.tracking._tracked_solve import TrackConfig

    cfg = TrackConfig()
    r_a = Rotation.from_euler("zyx", [10, 20, 30], degrees=True)
    step = Rotation.from_rotvec(np.radians([0.1, 0.05, 0.2]))  # per frame
    tracker = Tracker(cfg)
    tracker.history = [(3, r_a.as_matrix(), 1e-5), (5, (r_a * step * step).as_matrix(), 2e-5)]
    prior = tracker.predict(8)
    want = r_a * step ** 5
    assert (Rotation.from_matrix(prior.matrix).inv() * want).magnitude() < 1e-12
    sig_w = (math.hypot(1e-5, 2e-5) / 2 + cfg.accel_fraction * np.linalg.norm(step.as_rotvec())
             + cfg.rate_floor_rad)
    assert prior.sigma_rad == pytest.approx(2e-5 + 3 * sig_w, rel=1e-12)
    tracker.history = tracker.history[-1:]  # one attitude: no rate, the prior's own sigma
    alone = tracker.predict(6)
    assert np.allclose(alone.matrix, tracker.history[0][1], atol=1e-15)
    assert alone.sigma_rad == pytest.approx(2e-5 + cfg.unknown_rate_rad, rel=1e-12)
    assert tracker.predict(5 + cfg.max_coast_frames + 2) is None


def _write_profile(path, rows):
    path.write_text("t,qw,qx,qy,qz\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    return path


def test_profile_slerp_and_rate(tmp_path):
    q90 = Rotation.from_euler("z", 90, degrees=True).as_quat(scalar_first=True)
    path = _write_profile(tmp_path / "p.csv", [(0.0, 1, 0, 0, 0), (2.0, *q90)])
    profile = read_profile(path)
    mid = profile.at(np.array([1.0]))[0]
    assert abs(np.degrees(mid.magnitude()) - 45.0) < 1e-9
    assert np.allclose(mid.as_rotvec(), [0, 0, math.radians(45.0)])
    traj = profile_trajectory(profile, fps=4.0)
    assert len(traj) == 9  # 0, 0.25, ..., 2.0 s
    assert np.allclose(traj.rates_dps[1:-1], [0.0, 0.0, 45.0], atol=1e-6)
    with pytest.raises(InputError, match=r"9 frame\(s\) at 4 fps, not 10"):
        profile_trajectory(profile, fps=4.0, count=10)


@pytest.mark.parametrize("rows, message", [
    ([(0.0, 1, 0, 0, 0), (0.0, 1, 0, 0, 0)], "p.csv:3: times must increase"),
    ([(0.0, 1, 0, 0, 0)], "at least two rows"),
    ([(0.0, 0, 0, 0, 0), (1.0, 1, 0, 0, 0)], "p.csv:2: quaternion has zero length"),
])
def test_bad_profile_names_file_and_line(tmp_path, rows, message):
    with pytest.raises(InputError, match=message):
        read_profile(_write_profile(tmp_path / "p.csv", rows))


def _run(seq, hip_db, tracker=None):
    matcher = get_matcher("pyramid")(hip_db)
    matcher.prepare()
    tracker = tracker or Tracker()
    config = VerifyConfig()
    return [tracker.step(f.obs, hip_db, config, lambda o: identify(o, matcher, config),
                         "pyramid") for f in seq]


def _right(solution, frame) -> bool:
    ids = frame.truth_rows[solution.obs_index]
    return (boresight_error_arcsec(solution.rotation, frame.rotation) < 60.0
            and np.array_equal(ids, solution.cat_index))


def test_sequence_is_tracked_after_the_first_frame(hip_db):
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 12, 10.0, seed=2)
    sols = _run(seq, hip_db)
    assert [s.mode for s in sols] == ["lost_in_space"] + ["tracking"] * 11
    assert [s.lock for s in sols] == ["acquired"] + ["tracking"] * 11
    assert all(_right(s, f) for s, f in zip(sols, seq, strict=True))


def test_gap_and_jump_lose_lock_and_reacquire_by_lost_in_space(hip_db):
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 12, 10.0, seed=3,
                        blank=(4, 6), jump_at=6, jump_deg=10.0)
    sols = _run(seq, hip_db)
    assert [s.lock for s in sols] == (["acquired"] + ["tracking"] * 3 + ["lost", "none"]
                                      + ["reacquired"] + ["tracking"] * 5)
    assert sols[4].reason == "too_few_stars" and not sols[5].solved
    assert sols[6].mode == "lost_in_space" and _right(sols[6], seq[6])
    # A jump with no gap: tracking fails on the jumped frame, lost-in-space takes it.
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 6, 10.0, seed=4,
                        jump_at=3)
    sols = _run(seq, hip_db)
    assert [s.lock for s in sols] == ["acquired", "tracking", "tracking", "reacquired",
                                      "tracking", "tracking"]
    assert all(_right(s, f) for s, f in zip(sols, seq, strict=True))


def _coincidence(solution, frame, vectors: np.ndarray, radius_px: float) -> bool:
    """Every wrong identity is a false star within the match radius of the catalog star
    it was taken for, at the true attitude: a coincidence no verification can see."""
    cam = frame.obs.camera
    wrong = np.flatnonzero(frame.truth_rows[solution.obs_index] != solution.cat_index)
    for k in wrong:
        o = solution.obs_index[k]
        cat = frame.rotation.inv().apply(vectors[solution.cat_index[k]])
        x, y, _ = cam.vector_to_pixel(cat[None, :])
        if frame.truth_rows[o] >= 0 or math.hypot(x[0] - frame.obs.x[o],
                                                  y[0] - frame.obs.y[o]) > radius_px:
            return False
    return True


def test_many_false_stars_never_a_wrong_attitude(hip_db):
    """40 false stars and 40% of the stars missing per frame, 1 px noise: every tracked
    attitude is right, and a wrong identity is only a false star on a dropped star's spot."""
    cond = TrackCondition(rate_dps=3.0, noise_px=1.0, false_stars=40, missing=0.4)
    seq = make_sequence(hip_db.catalog, hip_db.camera, cond, 20, 10.0, seed=6)
    start = Prior.from_rotation(seq[0].rotation * Rotation.from_rotvec([1e-3, 0, 0]), 2e-3)
    sols = _run(seq, hip_db, Tracker(initial=start))
    assert sum(s.mode == "tracking" for s in sols) >= 18
    for s, f in zip(sols, seq, strict=True):
        assert not s.solved or boresight_error_arcsec(s.rotation, f.rotation) < 60.0
        assert not s.solved or _coincidence(s, f, hip_db.vectors,
                                             VerifyConfig().radius_px(f.obs))
    # Priors 3 deg off, believed to 0.05 deg, on the same frames: nothing is accepted.
    for f in seq[::4]:
        off = Prior.from_rotation(f.rotation * Rotation.from_rotvec([0, math.radians(3), 0]),
                                  math.radians(0.05))
        assert not track(f.obs, hip_db, off).solved


def test_a_wrong_prior_is_never_accepted(hip_db):
    """A prior 2 deg off, believed to 0.01 deg: tracking finds no verified match."""
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 1, 10.0, seed=7)
    obs, truth = seq[0].obs, seq[0].rotation
    near = Prior.from_rotation(truth * Rotation.from_rotvec([0.002, -0.001, 0.003]), 0.005)
    assert _right(track(obs, hip_db, near), seq[0])
    off = Prior.from_rotation(truth * Rotation.from_rotvec([math.radians(2), 0, 0]), 1.7e-4)
    result = track(obs, hip_db, off)
    assert not result.solved and result.reason == "no_track"


def test_time_ratios_pair_each_tracking_mode_with_its_own_lost_in_space():
    import pandas as pd

    from startrack.bench._tracking_report import VARIABLES, lost_in_space_name, time_ratios

    assert lost_in_space_name("pyramid+track") == "pyramid"
    assert lost_in_space_name("tetra3rs+hint") == "tetra3rs"
    assert lost_in_space_name("pyramid") is None
    rows = [("pyramid+track", 0.2), ("pyramid", 0.3), ("tetra3rs+hint", 0.1),
            ("tetra3rs", 0.4)]
    summary = pd.DataFrame([{"condition": 0, **dict.fromkeys(VARIABLES, 0.0), "method": m,
                             "time_median_ms": t} for m, t in rows])
    ratios = time_ratios(summary).set_index("method")["speed_up"]
    assert ratios.to_dict() == pytest.approx({"pyramid+track": 1.5, "tetra3rs+hint": 4.0})


_NO_JIT_SCRIPT = """
import sys
from startrack.bench._tracking_bench import TrackCondition, make_sequence
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.matchers import get_matcher
from startrack.sky import random_sky
from startrack.solver import identify
from startrack.tracking import Tracker
from startrack.verify import VerifyConfig

camera = Camera.from_fov(1024, 1024, 17.5)
db = StarDatabase(random_sky(2000, seed=11), camera)
matcher = get_matcher("pyramid")(db)
matcher.prepare()
config = VerifyConfig()
seq = make_sequence(db.catalog, camera, TrackCondition(), 4, 10.0, seed=3)
tracker = Tracker()
modes = [tracker.step(f.obs, db, config, lambda o: identify(o, matcher, config),
                      "pyramid").mode for f in seq]
print(modes.count("tracking"), any(m.split(".")[0] in ("numba", "llvmlite") for m in sys.modules))
"""


def test_a_tracked_sequence_runs_on_the_core_compiled_at_install(tmp_path):
    """Lost in space, then tracking, in a fresh process: the frames after the first are
    tracked, and no JIT compiler is ever loaded (every kernel was compiled at install,
    so no frame's time can hold a compile)."""
    env = dict(os.environ, STARTRACK_CACHE_DIR=str(tmp_path))
    assert run_python(_NO_JIT_SCRIPT, env=env).split() == ["3", "False"]
