"""The Python API (startrack.solve, startrack.Solver) on the real-sky test frame."""


import numpy as np
import pytest
from repo_paths import DATA

import startrack
from startrack.errors import InputError

FRAME = DATA / "realsky_azi45.png"
OPTIONS = dict(fov_deg=11.42, sky="hipparcos", epoch=2019.6)
AZI45 = (355.2046, 58.1518)  # tetra3's pointing (shared/real-sky/README.md)


@pytest.fixture(scope="module")
def solved():
    return startrack.solve(FRAME, **OPTIONS)


def test_solve_a_path_gives_the_reference_pointing(solved):
    assert solved.solved and solved.reason is None
    assert abs(solved.ra_deg - AZI45[0]) * np.cos(np.radians(AZI45[1])) < 30 / 3600
    assert abs(solved.dec_deg - AZI45[1]) < 30 / 3600
    assert np.isclose(np.linalg.norm(solved.quaternion), 1.0)
    assert solved.fov_deg == pytest.approx(11.42, abs=0.02)  # fitted (startrack.solver._fov_search)


def test_stars_are_hip_numbers_in_a_frame(solved):
    stars = solved.stars
    assert list(stars.columns) == ["x", "y", "catalog_id", "ra_deg", "dec_deg",
                                   "residual_arcsec"]
    assert len(stars) >= 30
    assert stars["catalog_id"].min() > 0  # HIP numbers, not 0-based rows
    assert solved.to_dict()["stars"][0]["catalog_id"] == int(stars["catalog_id"].iloc[0])


def test_solver_solves_centroid_arrays_and_image_arrays(solved):
    solver = startrack.Solver(size=(1024, 768), **OPTIONS)
    xy = solved.stars[["x", "y"]].to_numpy()
    again = solver.solve(xy)
    assert again.solved
    assert set(again.stars["catalog_id"]) <= set(solved.stars["catalog_id"])
    from startrack.io import read_image

    assert solver.solve(read_image(FRAME)).solved


def test_too_few_stars_is_not_solved_and_bad_arrays_are_input_errors():
    solver = startrack.Solver(size=(1024, 768), **OPTIONS)
    result = solver.solve(np.array([[10.0, 20.0], [30.0, 40.0]]))
    assert not result.solved and result.reason == "too_few_stars"
    assert result.ra_deg is None and result.stars.empty
    with pytest.raises(InputError):
        solver.solve(np.zeros((3, 3, 3)))
