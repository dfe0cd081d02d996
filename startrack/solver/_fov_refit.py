"""A solved answer at a nominal field of view, refitted: the focal length fitted to its
identified stars and the pointing verified again through the fitted camera."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from startrack.database import StarDatabase
from startrack.match_records import Hypothesis
from startrack.solver._deadline import NO_DEADLINE, Deadline
from startrack.solver._fov_fit import verify_fitted, weighed_first
from startrack.solver._fov_given import REFIT_HYPOTHESIS_STARS, given_stands, keep_given
from startrack.solver._fov_search import FovResult, _result
from startrack.verify import Verification, VerifyConfig


def refit_fov(result, database: StarDatabase, config: VerifyConfig,
              deadline: Deadline = NO_DEADLINE) -> FovResult | None:
    """A solved :class:`startrack.solver._identifier.FrameResult` made at a nominal FOV, with the
    focal length fitted to its identified stars and the pointing verified again through
    the fitted camera (:func:`verify_fitted`); None when that verification fails or
    ``deadline`` has already passed (the search after it then says "timeout"). Where the
    fitted camera does not fit the identified stars significantly better than the nominal
    one (:func:`given_stands`), the answer stands as it was made."""
    t0 = time.perf_counter()
    if deadline.passed():
        return None
    sol = result.solution
    if given_stands(result.camera, result.obs.x, result.obs.y, sol.obs_index,
                    database.vectors[sol.cat_index]):
        # the nominal camera was right: the answer made through it stands as it is
        spent = (time.perf_counter() - t0) * 1000.0
        return FovResult(dataclasses.replace(sol, identify_ms=sol.identify_ms + spent),
                         result.camera, result.obs, result.catalog, result.match_radius_px)
    k = min(REFIT_HYPOTHESIS_STARS, len(sol.obs_index))
    brightest = np.argsort(sol.obs_index)[:k]
    hyp = Hypothesis(sol.obs_index[brightest], sol.cat_index[brightest])
    # the answer's own matches start the fit: that verification at the nominal camera ran
    held = Verification(True, None, sol.obs_index, sol.cat_index, sol.false_probability,
                        len(sol.obs_index) - k)
    obs = result.obs
    found = weighed_first(lambda flux: verify_fitted(
        hyp, obs.x, obs.y, result.camera, result.sigma_px, database, config, held, flux),
        obs.flux, len(obs.x))
    if found is None:
        return None
    found = keep_given(found, result.camera, result.sigma_px, database, config)
    fitted = _result(found, result.catalog, sol.method, sol.diagnostics, t0, config, database)
    return fitted.plus_ms(sol.identify_ms)
