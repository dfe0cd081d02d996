"""The last check before an answer is reported as solved: its evidence must be there.

Verification accepts a hypothesis only with its stars confirmed; this gate holds every
path that reports an answer (the configured method, the FOV refit and search, the blind
search, tracking) to the same minimum, whatever went wrong upstream: a "solved" answer
must label at least :data:`MIN_MATCHED` stars, each with a finite residual, and its
residuals must be those of stars matched through its camera (RMS within the match
radius). Anything else is reported as not solved, reason ``unverified``: a wrong attitude
reported as right is the worst outcome, "not solved" is honest.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from startrack._core.track import HYPOTHESIS_STARS
from startrack.types import Solution
from startrack.verify._verification import VerifyConfig

#: a hypothesis's own stars plus the stars verification must confirm outside it
MIN_MATCHED = HYPOTHESIS_STARS + VerifyConfig().min_confirmed
ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0


def evidence_problem(solution: Solution, f_px: float, match_radius_px: float) -> str | None:
    """Why a solved ``solution`` lacks evidence (None when it has it, or is not solved).

    ``f_px``: the focal length of the camera it was solved through; ``match_radius_px``:
    how far a matched star may lie from its catalog star."""
    if not solution.solved:
        return None
    n = len(solution.obs_index)
    if n < MIN_MATCHED or len(solution.cat_index) != n or len(solution.residual_arcsec) != n:
        return f"{n} matched star(s), at least {MIN_MATCHED} needed"
    res = np.asarray(solution.residual_arcsec, dtype=np.float64)
    # numpy's mean of the squares, one reduction; a star with no finite residual leaves
    # the sum NaN or infinite (so may an overflow, which the RMS test then refuses)
    total = float(np.add.reduce(res * res))
    if not math.isfinite(total) and not np.all(np.isfinite(res)):
        return "a matched star has no finite residual"
    rms_px = math.sqrt(total / n) / ARCSEC_PER_RAD * f_px
    if not rms_px <= match_radius_px:
        return (f"residual RMS {rms_px:.2f} px exceeds the match radius "
                f"{match_radius_px:.2f} px (the camera does not fit the frame)")
    return None


def refuse_without_evidence(solution: Solution, f_px: float,
                            match_radius_px: float) -> Solution:
    """``solution`` unchanged, or not solved with reason ``unverified`` when
    :func:`evidence_problem` finds a problem."""
    if evidence_problem(solution, f_px, match_radius_px) is None:
        return solution
    return Solution(False, solution.method, diagnostics=solution.diagnostics,
                    identify_ms=solution.identify_ms, reason="unverified", mode=solution.mode,
                    lock=solution.lock)


def require_evidence(result):
    """``result`` (a :class:`startrack.solver._identifier.FrameResult`) with its solution passed
    through :func:`refuse_without_evidence`."""
    sol = refuse_without_evidence(result.solution, result.camera.f_px,
                                  result.match_radius_px)
    return result if sol is result.solution else dataclasses.replace(result, solution=sol)
