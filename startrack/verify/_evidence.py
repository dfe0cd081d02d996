"""The last check before an answer is reported as solved: its evidence must be there.

Verification accepts a hypothesis only with its stars confirmed; this gate holds every
path that reports an answer (the configured method, the FOV refit and search, the blind
search, tracking) to the same minimum, whatever went wrong upstream: a "solved" answer
must label at least :data:`MIN_MATCHED` stars, each with a finite residual, and its
residuals must be those of stars matched through its camera (RMS within the match
radius). Anything else is reported as not solved, reason ``unverified``: a wrong attitude
reported as right is the worst outcome, "not solved" is honest.

An answer must also explain the frame's bright stars (:func:`camera_problem`): through a
camera that does not fit (a principal point at (100, 900) declared centred) a hypothesis
can be confirmed by a dozen stars near where the two models agree, hundreds of arcsec
off, while most bright spots and most bright catalog stars in view stay unexplained; its
image centre then moves by about its error when the camera is refitted to the brightest
stars (:mod:`startrack.verify._refit`). Such an answer is refused, and its record says
why (``diagnostics.refused``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from startrack._core.tracking.tracked_frame import HYPOTHESIS_STARS
from startrack.database import held_cone_index
from startrack.match_records import Solution
from startrack.verify._refit import brightest_in_view, refit_camera
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


#: the brightest spots, and the brightest catalog stars the answer puts in the image,
#: that :func:`camera_problem` counts; a frame with fewer spots is not judged
BRIGHT_STARS = 20
#: an answer explaining less than this fraction of both is refused: the harsh set's right
#: answers (1 px, 5 false stars, 20% missing; scripts/validation/harsh_frames.py) explain at least
#: half of the bright spots, a centred camera for a (100, 900) principal point at most 35%
MIN_EXPLAINED = 0.4
#: an answer whose image centre moves more than the larger of these when its camera is
#: refitted (startrack.verify._refit) is refused, however many stars it labels: the move
#: is its error (offset principal points: within 0.1 px), and real frames' right answers
#: move at most 2 px, within 3.4 sigma
MAX_SHIFT_PX, MAX_SHIFT_SIGMAS = 1.0, 4.0
#: an answer that labels too few bright stars still stands when the refitted camera
#: explains enough of them and its centre moved at most the larger of these, never past
#: MAX_SHIFT_PX: the final labelling withholds stars of right answers on real frames
#: (saturated spots, thousands of false spots), not only of wrong ones
RESCUE_SHIFT_PX, RESCUE_SHIFT_SIGMAS = 0.5, 3.0


def explains_bright_spots(obs_index: np.ndarray, n_spots: int) -> bool:
    """Whether labels of the observed stars ``obs_index`` (of ``n_spots``, brightest
    first) name at least :data:`MIN_EXPLAINED` of the :data:`BRIGHT_STARS` brightest
    (a frame with fewer spots is not judged): the first test of :func:`camera_problem`."""
    return n_spots < BRIGHT_STARS or int(np.count_nonzero(
        np.asarray(obs_index) < BRIGHT_STARS)) >= MIN_EXPLAINED * BRIGHT_STARS


def camera_problem(solution: Solution, obs, camera, catalog, radius_px: float,
                   sigma_px: float) -> str | None:
    """Why a solved answer does not explain the frame (None when it does): its image
    centre moves past :data:`MAX_SHIFT_PX` and :data:`MAX_SHIFT_SIGMAS` when its camera is
    refitted to the brightest stars (:func:`startrack.verify._refit.refit_camera`), or it
    labels less than :data:`MIN_EXPLAINED` of the :data:`BRIGHT_STARS` brightest spots and
    of the brightest catalog stars it puts inside the image, and the refitted camera
    neither explains that many spots nor leaves the centre within
    :data:`RESCUE_SHIFT_PX` (or :data:`RESCUE_SHIFT_SIGMAS`)."""
    if not solution.solved or solution.rotation is None or len(obs.x) < BRIGHT_STARS:
        return None
    refit = refit_camera(solution.rotation, obs.x, obs.y, camera, catalog, radius_px,
                         sigma_px)
    if refit is not None and refit.shift_px > max(MAX_SHIFT_PX,
                                                   MAX_SHIFT_SIGMAS * refit.sigma_px):
        return (f"its image centre moves {refit.shift_px:.1f} px (1-sigma "
                f"{refit.sigma_px:.1f} px) when its camera is refitted to the brightest "
                "stars: the camera does not fit the frame (its principal point or lens?)")
    why = _labels_problem(solution, obs, camera, catalog)
    if why is None or refit is None:
        return why
    explained = np.count_nonzero(refit.explained < BRIGHT_STARS)
    if explained >= MIN_EXPLAINED * BRIGHT_STARS and refit.shift_px <= min(
            MAX_SHIFT_PX, max(RESCUE_SHIFT_PX, RESCUE_SHIFT_SIGMAS * refit.sigma_px)):
        return None
    return why


def _labels_problem(solution: Solution, obs, camera, catalog) -> str | None:
    """Why the answer's labels explain too little (None when they explain enough): less
    than :data:`MIN_EXPLAINED` of the :data:`BRIGHT_STARS` brightest spots and of the
    brightest catalog stars it puts inside the image are labelled."""
    if explains_bright_spots(solution.obs_index, len(obs.x)):
        return None
    spots = int(np.count_nonzero(np.asarray(solution.obs_index) < BRIGHT_STARS))
    seen, _ = brightest_in_view(catalog.vectors, solution.rotation.as_matrix(), camera,
                                BRIGHT_STARS, held_cone_index(catalog))
    stars = int(np.count_nonzero(np.isin(seen, solution.cat_index)))
    if len(seen) < BRIGHT_STARS / 2 or stars >= MIN_EXPLAINED * len(seen):
        return None
    return (f"explains {spots} of the {BRIGHT_STARS} brightest spots and {stars} of the "
            f"{len(seen)} brightest catalog stars it puts in the image: the camera does not "
            "fit the frame (its principal point or focal length?)")


def _refused(solution: Solution, why: str | None = None) -> Solution:
    diagnostics = solution.diagnostics
    if why is not None:
        diagnostics = dataclasses.replace(diagnostics,
                                          extra={**diagnostics.extra, "refused": why})
    return Solution(False, solution.method, diagnostics=diagnostics,
                    identify_ms=solution.identify_ms, reason="unverified", mode=solution.mode,
                    lock=solution.lock)


def refuse_without_evidence(solution: Solution, f_px: float,
                            match_radius_px: float) -> Solution:
    """``solution`` unchanged, or not solved with reason ``unverified`` when
    :func:`evidence_problem` finds a problem."""
    why = evidence_problem(solution, f_px, match_radius_px)
    return solution if why is None else _refused(solution, why)


def require_evidence(result, camera_checked: bool = False):
    """``result`` (a :class:`startrack.solver._identifier.FrameResult`) with its solution passed
    through :func:`refuse_without_evidence` and :func:`camera_problem`. ``camera_checked``:
    the camera already passed :func:`camera_problem` on an earlier frame of this sequence
    (a tracked frame's held camera), so its refit, ~13 ms, is not repeated per frame."""
    sol = refuse_without_evidence(result.solution, result.camera.f_px,
                                  result.match_radius_px)
    if sol is result.solution and not camera_checked:
        why = camera_problem(sol, result.obs, result.camera, result.catalog,
                             result.match_radius_px, result.sigma_px)
        sol = sol if why is None else _refused(sol, why)
    return result if sol is result.solution else dataclasses.replace(result, solution=sol)
