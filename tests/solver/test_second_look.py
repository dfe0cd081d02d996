"""Issue 49: a frame whose brightest spots are not stars (a burned-in caption, hot pixels,
nebula knots) is searched again past them, and the answer is numbered in the whole
frame; random spots stay unsolved."""

from __future__ import annotations

import numpy as np
import pytest
from test_principal_point import FOV, SIZE, WRONG_ARCSEC, _centroids

from startrack.api import Solver
from startrack.attitude import boresight_error_arcsec, random_attitudes
from startrack.camera import Camera
from startrack.sky import SkySpec, load_sky
from startrack.solver._deeper import SKIP

CAPTION = 12  # bright junk spots, brighter than every star


@pytest.fixture(scope="module")
def hipparcos():
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), Camera.from_fov(SIZE, SIZE, FOV))


def _captioned(hipparcos, seed: int):
    """A frame's stars (fluxes falling with rank) under a caption: CAPTION spots in a
    row along the bottom edge, brighter than any star. (spots, rotation)."""
    rng = np.random.default_rng(seed)
    rotation = random_attitudes(1, rng)[0]
    xy, _ = _centroids(hipparcos, Camera.from_fov(SIZE, SIZE, FOV), rotation, rng)
    stars = np.column_stack([xy, 1000.0 / (1.0 + np.arange(len(xy)))])
    caption = np.column_stack([40.0 + 23.0 * np.arange(CAPTION), np.full(CAPTION, 1000.0),
                               np.full(CAPTION, 5000.0)])
    return np.vstack([caption, stars]), rotation


@pytest.mark.parametrize("seed", [3, 4])
def test_a_captioned_frame_is_solved_past_its_caption(hipparcos, seed):
    spots, rotation = _captioned(hipparcos, seed)
    solver = Solver(fov_deg=FOV * 1.04, size=(SIZE, SIZE), sky="hipparcos", mag_limit=6.5)
    # the stars alone solve; with the caption on top the first look matches nothing
    assert solver.solve(spots[CAPTION:]).solved
    result = solver.solve(spots)
    record = result.to_dict()
    assert result.solved, record["steps"]
    assert any("second look" in s["stage"] for s in record["steps"])
    assert boresight_error_arcsec(rotation, result.frame.solution.rotation) < WRONG_ARCSEC
    labelled = result.frame.solution.obs_index
    assert labelled.min() >= SKIP and not np.isin(labelled, np.arange(CAPTION)).any()


def test_random_spots_get_no_second_look_answer():
    rng = np.random.default_rng(49)
    solver = Solver(fov_deg=FOV * 1.04, size=(SIZE, SIZE), sky="hipparcos", mag_limit=6.5)
    for _ in range(5):
        spots = np.column_stack([rng.uniform(0, SIZE - 1, (60, 2)), rng.uniform(1, 100, 60)])
        result = solver.solve(spots)
        assert not result.solved and result.reason == "no_match"
        assert any("second look" in s["stage"] for s in result.to_dict()["steps"])
