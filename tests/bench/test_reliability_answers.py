"""Issue 48, answers: the harsh set (1 px, 5 false stars, 20% missing) solved whole and
right through identify's path, and an answer through a camera that does not fit the
frame (principal point at (100, 900) declared centred) refused, saying why."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.api import Solver
from startrack.attitude import boresight_error_arcsec, random_attitudes
from startrack.bench._conditions import Condition
from startrack.bench._frames import make_frame
from startrack.camera import Camera
from startrack.sky import SkySpec, load_sky
from tests.solver.test_principal_point import FOV, SIZE, _centroids

HARSH = Condition(noise_px=1.0, false_stars=5, missing=0.2)
WRONG_ARCSEC = 60.0
#: harsh frames (seed 0) that the nominal FOV's first look and the search both missed
ONCE_LOST = (7, 63, 172, 194)


@pytest.fixture(scope="module")
def camera() -> Camera:
    return Camera.from_fov(SIZE, SIZE, FOV)


@pytest.fixture(scope="module")
def hipparcos(camera):
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), camera)


def _harsh(hipparcos, camera, frames) -> dict[str, list[int]]:
    """The harsh frames solved through Solver (identify's path: nominal FOV, first look,
    refit, search, evidence): the frames not solved and those solved wrong."""
    solver = Solver(camera=camera, sky="hipparcos", mag_limit=6.5)
    out = {"unsolved": [], "wrong": []}
    for i in frames:
        frame = make_frame(hipparcos, camera, HARSH, 0, i)
        spots = np.column_stack([frame.obs.x, frame.obs.y, frame.obs.flux])
        result = solver.solve(spots)
        if not result.solved:
            out["unsolved"].append(i)
            continue
        sol = result.frame.solution
        ids = frame.truth_rows[sol.obs_index]
        if (boresight_error_arcsec(frame.rotation, sol.rotation) > WRONG_ARCSEC
                or np.any(ids != sol.cat_index)):
            out["wrong"].append(i)
    return out


def test_the_harsh_frames_once_lost_are_solved_right(hipparcos, camera):
    assert _harsh(hipparcos, camera, ONCE_LOST) == {"unsolved": [], "wrong": []}


@pytest.mark.slow
def test_the_harsh_set_is_solved_whole_and_right(hipparcos, camera):
    assert _harsh(hipparcos, camera, range(200)) == {"unsolved": [], "wrong": []}


def test_a_centred_camera_for_an_offset_principal_point_is_refused_saying_why(hipparcos):
    # Issue 48: 3 of 5 such frames were "solved", hundreds of arcsec off, 9-21 of 51-144
    # stars explained; at this seed all 5 were, 11 deg from the true boresight.
    rng = np.random.default_rng(5)
    true = Camera.from_fov(SIZE, SIZE, FOV, 100.0, 900.0)
    solver = Solver(camera=Camera.from_fov(SIZE, SIZE, FOV), sky="hipparcos")
    refused = 0
    for _ in range(5):
        rotation = random_attitudes(1, rng)[0]
        xy, _ = _centroids(hipparcos, true, rotation, rng)
        result = solver.solve(xy)
        assert not result.solved, boresight_error_arcsec(rotation,
                                                         result.frame.solution.rotation)
        record = result.to_dict()
        if result.reason == "unverified":
            refused += 1
            assert "does not fit the frame" in record["diagnostics"]["refused"]
    assert refused >= 3
