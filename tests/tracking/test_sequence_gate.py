"""The evidence gate's camera check in a sequence: run once on the lost-in-space answer that
sets the held camera, not again on every tracked frame through it (its refit costs ~13 ms,
a tracked frame well under one); a prior's camera, never checked, is checked per frame; and
a camera the check refused is checked again on every frame."""

from __future__ import annotations

import numpy as np
import pytest

import startrack.verify._evidence as evidence
from startrack import Solver
from startrack.attitude import from_radec_roll, to_radec_roll
from startrack.camera import Camera
from startrack.simulate import observe
from startrack.sky import load_sky

CAMERA = Camera.from_fov(1024, 1024, 20.0)


@pytest.fixture(scope="module")
def frames():
    sky = load_sky("random", CAMERA)
    rng = np.random.default_rng(3)
    rotations = [from_radec_roll(120.0 + 0.05 * k, -30.0, 15.0) for k in range(4)]
    scenes = [observe(sky, CAMERA, rot, rng) for rot in rotations]
    return [np.column_stack([s.x, s.y]) for s in scenes], rotations


@pytest.fixture
def checks(monkeypatch):
    calls = []
    real = evidence.camera_problem

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(evidence, "camera_problem", counted)
    return calls


def test_a_tracked_frame_keeps_the_check_its_lost_in_space_answer_passed(frames, checks):
    centroids, _ = frames
    solver = Solver(fov_deg=20.0, size=(1024, 1024), sky="random", track=True)
    modes = [solver.solve(c).mode for c in centroids]
    assert modes == ["lost_in_space", "tracking", "tracking", "tracking"]
    assert len(checks) == 1


def test_a_prior_camera_is_checked_on_every_frame(frames, checks):
    centroids, rotations = frames
    solver = Solver(fov_deg=20.0, size=(1024, 1024), sky="random", track=True,
                    prior=tuple(to_radec_roll(rotations[0])))
    results = [solver.solve(c) for c in centroids]
    assert all(r.solved and r.mode == "tracking" for r in results)
    assert len(checks) == len(centroids)


def test_a_camera_the_check_refuses_is_checked_again(frames, monkeypatch):
    """A refused answer's camera may still carry a prediction to the next frame, but
    never as a checked camera: that frame's answer is checked again, and refused again."""
    centroids, _ = frames
    calls = []

    def refuse(*args, **kwargs):
        calls.append(1)
        return "refused for the test"

    monkeypatch.setattr(evidence, "camera_problem", refuse)
    solver = Solver(fov_deg=20.0, size=(1024, 1024), sky="random", track=True)
    results = [solver.solve(c) for c in centroids[:3]]
    assert [r.solved for r in results] == [False, False, False]
    assert len(calls) == 3
