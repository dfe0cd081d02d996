"""How far an answer moves when its camera is refitted: whether the camera fits the frame.

An answer through a camera that does not fit (a principal point at (100, 900) declared
centred) and an answer whose stars the final labelling was wary of (saturated spots,
thousands of false spots, a little lens distortion) can both label few of the bright
spots. They differ in what the bright spots say once the camera is free: the brightest
spots are paired with the brightest catalog stars the answer puts in the image, and the
attitude, focal length, principal point and k1 are fitted to those pairs. Where the
camera did not fit, the image centre's direction moves by about the answer's own error
(simulated offset principal points: the move is within 0.1 px of the true error); where it
fitted, it stays within the fit's own uncertainty. :func:`refit_camera` returns that move
and its 1-sigma (from the fit's covariance), with the spots the refitted camera explains.
The pairing and the fit are compiled (``startrack/_core/verify/camera_refit.pyx``): every
answer passes through them, and in numpy they were most of a solve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack._core.verify import camera_refit
from startrack.database import held_cone_index

#: the brightest spots paired, and the brightest catalog stars in the image they pair with
#: (more than the 20 judged: a bright spot's star may be fainter in the catalog's band)
SPOTS = 40
CATALOG_STARS = 60
#: fewer pairs than this fit no 7-parameter camera worth believing
MIN_PAIRS = 8
#: each round's pairing radius in match radii, wide first (the answer's camera may put a
#: star several pixels off), and whether k1 is free: fixed at first, as k1 can trade for
#: an offset principal point and lead the fit into a false minimum (a corner principal
#: point taken for k1 = -0.44, the move then 0.5 px for an answer 3.4 px off)
ROUNDS = ((3.0, False), (2.0, False), (1.0, False), (1.0, True), (1.0, True))
#: Levenberg-Marquardt steps per round at most: the principal point and the attitude
#: nearly trade off, so a few plain Gauss-Newton steps stop short (and an unconverged fit
#: overstates the move's uncertainty)
ITERATIONS = 40
#: the first step's damping, relative to the curvature: the answer's camera starts near
#: the minimum, where a Gauss-Newton step is right (1e-3 held back the near-degenerate
#: principal point / attitude direction, and shedding it tenfold a step cost ~6 steps a
#: round)
DAMPING = 1e-7
#: a scan for the brightest in view that would pass more rows than this looks up the
#: catalog's cone instead, where the cone's rows, each costing what this many rows of the
#: scan do (gathered, tested, sorted), cost less: a lookup costs about what 3,000 to
#: 8,000 rows of the scan do in a solve (measured at 11.4, 20 and 30 deg), and a deep
#: blind catalog's cone at 11.4 deg (2,300 of Gaia's rows) more than its scan
CONE_FROM_ROWS, CONE_ROW_COST = 8000, 16
#: the rounds that free k1 are run only where the pairs support a k1 other than the
#: camera's: k1's score test at the fit that held it (the efficient score squared over its
#: variance, a chi-square of one degree of freedom) beyond 3 sigma, the project's
#: significance. Short of that, freeing k1 moves the fit, and the centre, by less than the
#: noise: on simulated answers at 11.4, 20 and 30 deg, skipping those rounds always moved
#: the centre by under 4 % of its refusal threshold (and the rounds are a third of a refit)
K1_CHI2 = 9.0
#: the rules above as the compiled refit takes them
RULES = camera_refit.RefitRules([factor for factor, _ in ROUNDS],
                                [free for _, free in ROUNDS], MIN_PAIRS, ITERATIONS, DAMPING,
                                K1_CHI2)


@dataclass(frozen=True)
class Refit:
    """The refitted camera's verdict: which of the brightest spots it explains (indices,
    ascending), and how far (px) the image centre's direction moved, with its 1-sigma."""

    explained: np.ndarray
    shift_px: float
    sigma_px: float


def refit_camera(rotation, x, y, camera, catalog, radius_px: float,
                 sigma_px: float) -> Refit | None:
    """:class:`Refit` of an answer (``rotation`` through ``camera``, the spots at ``x``,
    ``y`` brightest first, matched within ``radius_px``; ``sigma_px``: the least
    centroid error the residuals are taken to have); None when too few pairs fit."""
    matrix = rotation.as_matrix()  # camera to sky: its last column is the boresight
    _, v = brightest_in_view(catalog.vectors, matrix, camera, cone=held_cone_index(catalog))
    return refit_stars(v, np.asarray(x[:SPOTS], np.float64), np.asarray(y[:SPOTS], np.float64),
                       camera, radius_px, sigma_px)


def brightest_in_view(vectors: np.ndarray, matrix: np.ndarray, camera,
                      n: int = CATALOG_STARS, cone=None) -> tuple[np.ndarray, np.ndarray]:
    """(rows, camera-frame vectors) of the ``n`` brightest catalog stars (rows of the
    brightest-first ``vectors``) that camera-to-sky ``matrix`` puts in the image
    (compiled: a scan that stops at the ``n``-th). ``cone``: a ConeIndex of ``vectors``,
    whose rows within the image's half-diagonal are scanned in place of every row where
    the scan would pass more than :data:`CONE_FROM_ROWS` and the cone's rows cost less
    (:data:`CONE_ROW_COST`; a narrow field cut deep: the whole catalog passes before ``n``
    fall in the image); the same rows either way."""
    cos_limit = math.cos(math.radians(camera.half_diagonal_deg))
    vectors = np.ascontiguousarray(vectors, np.float64)
    matrix = np.ascontiguousarray(matrix, np.float64)
    share = (1.0 - cos_limit) / 2.0  # of the sky within the half-diagonal
    # the rows the scan passes: the whole catalog, or until n fall in the image (2/pi of
    # the half-diagonal's cone)
    passed = min(len(vectors), n / (share * 2.0 / math.pi))
    rows = None
    if cone is not None and passed > CONE_FROM_ROWS and \
            len(vectors) * share * CONE_ROW_COST < passed:
        # widened a hair: the lookup's >= test at the cosine of the angle holds every row
        # the scan's own > test at cos_limit keeps
        rows = cone.rows(matrix[:, 2], math.acos(cos_limit) * (1.0 + 1e-9) + 1e-12)
    return camera_refit.brightest_in_view(camera.optics, vectors, matrix, cos_limit, n, rows)


def refit_stars(v: np.ndarray, x: np.ndarray, y: np.ndarray, camera, radius_px: float,
                sigma_px: float) -> Refit | None:
    """:func:`refit_camera` of catalog stars at camera-frame vectors ``v`` (brightest
    first) and spots at ``x``, ``y`` (brightest first)."""
    fitted = camera_refit.refit(camera.optics, np.ascontiguousarray(v, np.float64),
                                np.ascontiguousarray(x, np.float64),
                                np.ascontiguousarray(y, np.float64), radius_px, sigma_px, RULES)
    return None if fitted is None else Refit(*fitted)
