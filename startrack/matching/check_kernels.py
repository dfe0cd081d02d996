"""Compiled verification of one hypothesis in one call: the first test, the binomial bound
on a coincidence, the acceptance, the refinement, the final labelling, the residuals and
the attitude's quaternion (:func:`startrack.verify._verification.verify`, step for step).

A solved frame used to cross from Python into compiled code and back at every step, with
the arrays rebuilt in between; here the frame's constants come packed once per frame
(:func:`pack_params`) and one call returns the verdict.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching import verify_kernels as kern
from startrack.matching.cone_kernels import cone_rows
from startrack.matching.labelling_kernels import label_kernel
from startrack.matching.wahba_kernels import matrix_to_quaternion, wahba

#: What :func:`check_cone` / :func:`check_fixed` found (their first return value).
BAD_INDEX, REJECTED, NOT_ACCEPTED, ACCEPTED, BEYOND_CONE = 0, 1, 2, 3, 4
_ARCSEC = 180.0 / np.pi * 3600.0
# cephes' MINLOG, log(2^-1022): below it scipy's bdtrc underflows to 0
_MIN_LOG = -7.08396418532264106224e2
# The layout of ``params`` (see pack_params).
(_RADIUS, _COS_RADIUS, _CONE_RADIUS, _MARGIN_COS, _CAPTURE, _ROUNDS, _MIN_CONFIRMED,
 _MAX_PROB, _R2, _AREA, _HAS_FLUX, _SIGMA0, _GAP, _LOG_FALSE, _RESOLVE2, _MAG_SIGMAS,
 _MIN_MAG_SIGMA, _MIN_SIGMA_PX, _MIN_FIT, N_PARAMS) = range(20)


def pack_params(radius_px: float, cos_radius: float, cone_radius: float, margin_cos: float,
                capture: float, max_rounds: int, min_confirmed: int, max_probability: float,
                label_params: tuple) -> np.ndarray:
    """The frame's constants as the check kernels take them: the projector's match radius
    (px), the hypothesis's fit cosine, the cone radius, the cone reuse cosine (-2: rows
    fixed), the refinement's capture and rounds, the acceptance thresholds, then
    :func:`startrack.verify._labelling.kernel_params` without its flux (``radius2`` ...)."""
    _, has_flux, radius2, sigma0, area, *rest = label_params
    return np.array([radius_px, cos_radius, cone_radius, margin_cos, capture, max_rounds,
                     min_confirmed, max_probability, radius2, area, float(has_flux), sigma0,
                     *rest], dtype=np.float64)


@njit(cache=True)
def binomial_tail(k, n, p):
    """P(X > k) for X ~ Binomial(n, p), as ``scipy.special.bdtrc(k, n, p)`` over the range
    verification uses (0 <= k < n, 0 <= p <= 1), 0 where scipy's underflows: the largest
    term of the tail in log space, the others by their ratios, summed until negligible
    (the terms fall off on both sides of the binomial's mode)."""
    if k < 0:
        return 1.0
    if k >= n or p <= 0.0:
        return 0.0
    if p >= 1.0:
        return 1.0
    odds = p / (1.0 - p)
    top = max(k + 1, min(n, int((n + 1) * p)))  # the mode, or the tail's first term
    log_top = (math.lgamma(n + 1.0) - math.lgamma(top + 1.0) - math.lgamma(n - top + 1.0)
               + top * math.log(p) + (n - top) * math.log1p(-p))
    total, ratio = 1.0, 1.0
    for j in range(top, n):  # t(j + 1) / t(j) = (n - j) / (j + 1) * odds
        ratio *= (n - j) / (j + 1.0) * odds
        total += ratio
        if ratio <= 1e-17 * total:
            break
    ratio = 1.0
    for j in range(top, k + 1, -1):  # t(j - 1) / t(j) = j / ((n - j + 1) odds)
        ratio *= j / ((n - j + 1.0) * odds)
        total += ratio
        if ratio <= 1e-17 * total:
            break
    log_total = log_top + math.log(total)
    if log_total < _MIN_LOG:
        return 0.0
    return min(1.0, math.exp(log_total))


@njit(cache=True)
def _valid(index, size):
    """Whether ``index`` holds distinct values in [0, size) (a hypothesis has a few)."""
    for a in range(index.shape[0]):
        if index[a] < 0 or index[a] >= size:
            return False
        for b in range(a):
            if index[b] == index[a]:
                return False
    return True


@njit(cache=True)
def scipy_quaternion(matrix):
    """The quaternion ``[x, y, z, w]`` of ``matrix`` normalised as scipy's
    ``Rotation.from_quat`` normalises it (so that a Rotation built on it without that step
    holds the same numbers)."""
    q = matrix_to_quaternion(matrix)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] /= norm
    return q


@njit(cache=True)
def _verdict(obs_vectors, ox, oy, flux, hyp_obs, matrix, rows, vectors, mags, geometry,
             params):
    """Everything after the first attitude: the frame matched at it, the bound, the
    acceptance, then refinement, labelling, residuals and quaternion. Returns (status,
    observed index, catalog row, probability, confirmed, final matrix, residuals in
    arcseconds, quaternion)."""
    none_f = np.zeros(0)
    obs_m, pos, n_in = kern.match(vectors, matrix, ox, oy, geometry, params[_RADIUS])
    confirmed = kern.confirmed_count(obs_m, hyp_obs, ox.shape[0])
    prob = 1.0
    if confirmed > 0:
        p = min(1.0, n_in * math.pi * params[_R2] / params[_AREA])
        prob = binomial_tail(confirmed - 1, ox.shape[0] - hyp_obs.shape[0], p)
    if not (confirmed >= params[_MIN_CONFIRMED] and prob <= params[_MAX_PROB]):
        return NOT_ACCEPTED, obs_m, rows[pos], prob, confirmed, matrix, none_f, none_f
    obs_r, pos_r, refined, px, py, valid, projected = kern.refine_projected(
        obs_vectors, ox, oy, vectors, geometry, params[_RADIUS], params[_CAPTURE], obs_m, pos,
        int(params[_ROUNDS]))
    drift = refined[0, 2] * matrix[0, 2] + refined[1, 2] * matrix[1, 2] \
        + refined[2, 2] * matrix[2, 2]
    if drift < params[_MARGIN_COS]:  # beyond the cone's margin: the caller goes step by step
        return BEYOND_CONE, obs_m, rows[pos], prob, confirmed, matrix, none_f, none_f
    px, py, inside = kern.project_refined(vectors, geometry, params[_RADIUS], refined, px, py,
                                          valid, projected)
    sel = np.flatnonzero(inside)
    obs_i, cat_pos, _, _, _, _ = label_kernel(
        ox, oy, px[sel], py[sel], mags[sel], sel, flux, params[_HAS_FLUX] > 0.0,
        params[_R2], params[_SIGMA0], params[_AREA], params[_GAP], params[_LOG_FALSE],
        params[_RESOLVE2], params[_MAG_SIGMAS], params[_MIN_MAG_SIGMA],
        params[_MIN_SIGMA_PX], int(params[_MIN_FIT]))
    final = refined
    if obs_i.shape[0] >= 3:
        final = wahba(obs_vectors[obs_i], vectors[cat_pos])
    resid, quat = reported(obs_vectors, obs_i, final, vectors[cat_pos])
    return ACCEPTED, obs_i, rows[cat_pos], prob, confirmed, final, resid, quat


@njit(cache=True)
def reported(obs_vectors, obs_index, matrix, cat_vectors):
    """What an accepted attitude reports with its identities: each identified star's
    residual in arcseconds (:func:`~startrack.matching.verify_kernels.residual_angles`)
    and scipy's quaternion of ``matrix`` (:func:`scipy_quaternion`)."""
    resid = kern.residual_angles(obs_vectors, obs_index, matrix, cat_vectors) * _ARCSEC
    return resid, scipy_quaternion(matrix)


@njit(cache=True)
def _first(obs_vectors, hyp_obs, hyp_rows, catalog, params):
    """The hypothesis's attitude and whether each of its pairs fits within the radius."""
    sky = np.empty((hyp_rows.shape[0], 3))
    for k in range(hyp_rows.shape[0]):
        sky[k] = catalog[hyp_rows[k]]
    cam = obs_vectors[hyp_obs]
    matrix = wahba(cam, sky)
    return matrix, kern.fits_within(cam, sky, matrix, params[_COS_RADIUS])


@njit(cache=True)
def check_cone(obs_vectors, ox, oy, flux, hyp_obs, hyp_rows, catalog, mags, order, ra_sorted,
               band_start, geometry, params):
    """Verify one hypothesis (observed ``hyp_obs[k]`` is catalog row ``hyp_rows[k]``) on
    the catalog cone around its attitude. Returns (status, first matrix, cone rows, cone
    vectors, observed index, catalog rows, probability, confirmed, final matrix,
    residuals, quaternion); the index pairs are the first test's unless ACCEPTED."""
    none_i, none_f = np.zeros(0, np.int64), np.zeros(0)
    eye = np.eye(3)
    if not (_valid(hyp_obs, ox.shape[0]) and _valid(hyp_rows, catalog.shape[0])) \
            or hyp_obs.shape[0] < 3 or hyp_obs.shape[0] != hyp_rows.shape[0]:
        return (BAD_INDEX, eye, none_i, np.zeros((0, 3)), none_i, none_i, 1.0, 0, eye,
                none_f, none_f)
    matrix, fits = _first(obs_vectors, hyp_obs, hyp_rows, catalog, params)
    if not fits:
        return (REJECTED, matrix, none_i, np.zeros((0, 3)), none_i, none_i, 1.0, 0, matrix,
                none_f, none_f)
    rows = cone_rows(catalog, order, ra_sorted, band_start, matrix[:, 2].copy(),
                     params[_CONE_RADIUS])
    vectors = np.empty((rows.shape[0], 3))
    cone_mags = np.empty(rows.shape[0])
    for i in range(rows.shape[0]):
        vectors[i] = catalog[rows[i]]
        cone_mags[i] = mags[rows[i]]
    status, obs_m, cat_m, prob, confirmed, final, resid, quat = _verdict(
        obs_vectors, ox, oy, flux, hyp_obs, matrix, rows, vectors, cone_mags, geometry,
        params)
    return (status, matrix, rows, vectors, obs_m, cat_m, prob, confirmed, final, resid,
            quat)


@njit(cache=True)
def check_fixed(obs_vectors, ox, oy, flux, hyp_obs, hyp_rows, catalog, rows, vectors, mags,
                geometry, params):
    """:func:`check_cone` over given catalog rows (``vectors``, ``mags``: theirs) instead
    of a cone. Returns (status, first matrix, observed index, catalog rows, probability,
    confirmed, final matrix, residuals, quaternion)."""
    none_i, none_f = np.zeros(0, np.int64), np.zeros(0)
    eye = np.eye(3)
    if not (_valid(hyp_obs, ox.shape[0]) and _valid(hyp_rows, catalog.shape[0])) \
            or hyp_obs.shape[0] < 3 or hyp_obs.shape[0] != hyp_rows.shape[0]:
        return BAD_INDEX, eye, none_i, none_i, 1.0, 0, eye, none_f, none_f
    matrix, fits = _first(obs_vectors, hyp_obs, hyp_rows, catalog, params)
    if not fits:
        return REJECTED, matrix, none_i, none_i, 1.0, 0, matrix, none_f, none_f
    status, obs_m, cat_m, prob, confirmed, final, resid, quat = _verdict(
        obs_vectors, ox, oy, flux, hyp_obs, matrix, rows, vectors, mags, geometry, params)
    return status, matrix, obs_m, cat_m, prob, confirmed, final, resid, quat


def warm_up() -> None:
    """Compile (or load from numba's cache) both check kernels on a tiny input, so that no
    timed frame compiles them."""
    from startrack.database.cone import ConeIndex

    v = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.0]])
    v /= np.sqrt((v * v).sum(axis=1))[:, None]
    xy = np.array([1.0, 2.0, 3.0])
    geometry = np.array([100.0, 1.0, 1.0, 4.0, 4.0, 0.0, 0.0, 0.0, np.inf])
    idx = np.arange(3)
    params = pack_params(1.0, 0.5, 0.1, 0.9, 3.0, 2, 2, 1e-9,
                         (xy, True, 1.0, 1.0, 16.0, -6.9, -6.9, 4.0, 5.0, 0.03, 0.02, 5))
    index = ConeIndex.build(v)
    check_cone(v, xy, xy, xy, idx, idx, index.vectors, xy, index.order, index.ra_sorted,
               index.band_start, geometry, params)
    check_fixed(v, xy, xy, xy, idx, idx, v, idx, v, xy, geometry, params)
