"""The focal-length and blind searches weigh the stars' measured brightness as every other
path does: their final labelling once saw pixels only, and named a false star of the
wrong brightness that happened to lie within the match radius of a catalog star (harsh
frame 203 of seed 3: 2.1 px from HIP row 2763, at 1 px noise), where the exact FOV's
labelling, with the fluxes, withheld it."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.bench import Condition, make_frame
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.sky import SkySpec, load_sky
from startrack.solver import Options, Pipeline
from startrack.solver._fov_fit import rounds_for
from startrack.solver._inputs import FrameInput
from startrack.verify import VerifyConfig

CAMERA = Camera.from_fov(1024, 1024, 20.0)
HARSH = Condition(noise_px=1.0, false_stars=5, missing=0.2)


@pytest.fixture(scope="module")
def hipparcos():
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), CAMERA)


def _input(frame, photometric: bool = True) -> FrameInput:
    obs = frame.obs
    return FrameInput("harsh", Centroids(obs.x, obs.y, obs.flux, photometric=photometric))


@pytest.mark.parametrize("fov_deg", [20.0, None])  # nominal (10 %) and blind
def test_a_search_does_not_name_a_false_star_of_the_wrong_brightness(hipparcos, fov_deg):
    frame = make_frame(hipparcos, CAMERA, HARSH, 3, 203)
    options = Options(fov_deg=fov_deg, size=(1024, 1024), sky="hipparcos", mag_limit=6.5,
                      sigma_px=1.0, max_stars=8)
    result = Pipeline(options).solve(_input(frame))
    sol = result.solution
    assert sol.solved and sol.method == "quad"
    assert result.obs.flux is not None  # the search's stars carry their fluxes
    named = frame.truth_rows[sol.obs_index]
    rows = result.catalog.ids[sol.cat_index]
    assert np.all(named >= 0), "a false star was named"
    assert np.array_equal(hipparcos.ids[named], rows)


def test_fluxes_that_only_rank_the_stars_are_not_weighed(hipparcos):
    frame = make_frame(hipparcos, CAMERA, HARSH, 3, 203)
    options = Options(fov_deg=20.0, size=(1024, 1024), sky="hipparcos", mag_limit=6.5,
                      sigma_px=1.0, max_stars=8)
    result = Pipeline(options).solve(_input(frame, photometric=False))
    assert result.solution.solved and result.obs.flux is None


def test_the_compiled_rounds_take_fluxes_only_where_their_labelling_weighs_them(hipparcos):
    from startrack.database import StarDatabase

    frame = make_frame(hipparcos, CAMERA, HARSH, 3, 203)
    db = StarDatabase(hipparcos, CAMERA)
    x, y, flux = frame.obs.x, frame.obs.y, frame.obs.flux
    with_flux = rounds_for(x, y, CAMERA, 1.0, db, VerifyConfig(), flux)
    without = rounds_for(x, y, CAMERA, 1.0, db, VerifyConfig())
    assert with_flux is not without
    with pytest.raises(ValueError, match="does not weigh"):
        without.with_pixels(np.ascontiguousarray(x), np.ascontiguousarray(y),
                            np.ascontiguousarray(flux))
    with pytest.raises(ValueError, match="unequal lengths"):
        with_flux.with_pixels(np.ascontiguousarray(x), np.ascontiguousarray(y),
                              np.ascontiguousarray(flux[:-1]))
