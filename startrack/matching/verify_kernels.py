"""Compiled arithmetic of verification: the catalog projected through an attitude and a
lens, observed stars paired with it, a hypothesis's first test and the refinement loop.

A frame has tens of stars, so numpy or scipy on them is dominated by per-call overhead;
these kernels do a whole step per call. The camera comes in as ``geometry``:
``[f_px, cx, cy, width, height, k1, k2, k3, max_r2]`` (:func:`startrack.camera._model.geometry`),
and the projection is :meth:`startrack.camera._model.Camera.vector_to_pixel` followed by
:meth:`~startrack.camera._model.Camera.in_image`, operation for operation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching.cone_kernels import cone_rows
from startrack.matching.labelling_kernels import label_kernel
from startrack.matching.nearest_kernels import nearest_matches
from startrack.matching.wahba_kernels import matrix_to_quaternion, wahba


@njit(cache=True)
def fits_within(cam, sky, matrix, cos_radius):
    """Whether every pair lies within the match radius of the other at ``matrix``."""
    for k in range(cam.shape[0]):
        dot = 0.0
        for i in range(3):
            dot += (matrix[i, 0] * cam[k, 0] + matrix[i, 1] * cam[k, 1]
                    + matrix[i, 2] * cam[k, 2]) * sky[k, i]
        if dot < cos_radius:
            return False
    return True


@njit(cache=True)
def fits_hypothesis(obs_vectors, hyp_obs, sky, cos_radius):
    """Verification's first test of a hypothesis (observed ``hyp_obs[k]`` is the catalog
    vector ``sky[k]``) on its own: whether every pair lies within the match radius of the
    other at their Wahba fit. A matcher that screens its hypotheses with it hands
    verification none that this test would refuse."""
    cam = obs_vectors[hyp_obs]
    return fits_within(cam, sky, wahba(cam, sky), cos_radius)


@njit(cache=True)
def fitting_rows(obs_vectors, hyp_obs, rows, row_vectors, cos_radius):
    """The hypotheses (``rows``: one per hypothesis, its catalog stars for the observed
    ``hyp_obs``, as rows of ``row_vectors``) that pass :func:`fits_hypothesis`; all of
    them when ``cos_radius`` is below -1 (no test)."""
    if cos_radius < -1.0:
        return rows
    keep = np.zeros(rows.shape[0], np.bool_)
    sky = np.empty((hyp_obs.shape[0], 3))
    for h in range(rows.shape[0]):
        for k in range(hyp_obs.shape[0]):
            sky[k] = row_vectors[rows[h, k]]
        keep[h] = fits_hypothesis(obs_vectors, hyp_obs, sky, cos_radius)
    return rows[keep]


@njit(cache=True)
def project(vectors, matrix, geometry, margin):
    """Pixel positions of catalog vectors (n, 3) at the attitude ``matrix`` (camera to sky)
    and whether each falls in the image widened by ``margin`` pixels (negative: narrowed).
    A star behind the camera, or beyond the radius where the lens model folds back, is out."""
    px, py, valid = project_valid(vectors, matrix, geometry)
    return px, py, within(px, py, valid, geometry, margin)


@njit(cache=True)
def project_valid(vectors, matrix, geometry):
    """:func:`project`'s positions (0 where there is none) and which stars have one: in
    front of the camera and inside the lens model's fold radius."""
    f, cx, cy = geometry[0], geometry[1], geometry[2]
    k1, k2, k3, max_r2 = geometry[5], geometry[6], geometry[7], geometry[8]
    n = vectors.shape[0]
    px = np.zeros(n)
    py = np.zeros(n)
    valid = np.zeros(n, np.bool_)
    for i in range(n):
        a, b, c = vectors[i, 0], vectors[i, 1], vectors[i, 2]  # R^T v: in the camera frame
        vx = a * matrix[0, 0] + b * matrix[1, 0] + c * matrix[2, 0]
        vy = a * matrix[0, 1] + b * matrix[1, 1] + c * matrix[2, 1]
        vz = a * matrix[0, 2] + b * matrix[1, 2] + c * matrix[2, 2]
        if vz <= 1e-12:
            continue
        u, w = vx / vz, vy / vz
        r2 = u * u + w * w
        if not r2 < max_r2:
            continue
        s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        px[i], py[i] = cx + f * (u * s), cy + f * (w * s)
        valid[i] = True
    return px, py, valid


@njit(cache=True)
def within(px, py, valid, geometry, margin):
    """Which projected stars fall in the image widened by ``margin`` pixels."""
    width, height = geometry[3], geometry[4]
    lo_x, hi_x = -0.5 - margin, width - 0.5 + margin
    lo_y, hi_y = -0.5 - margin, height - 0.5 + margin
    inside = np.zeros(px.shape[0], np.bool_)
    for i in range(px.shape[0]):
        inside[i] = valid[i] and lo_x <= px[i] <= hi_x and lo_y <= py[i] <= hi_y
    return inside


@njit(cache=True)
def match(vectors, matrix, ox, oy, geometry, radius):
    """Observed stars paired with the catalog vectors that fall in the image widened by
    ``radius`` (a star just beyond the edge can still be an observed star's) at ``matrix``:
    (observed index ascending, vector position, how many vectors fall in it)."""
    px, py, valid = project_valid(vectors, matrix, geometry)
    return match_projected(px, py, valid, ox, oy, geometry, radius)


@njit(cache=True)
def match_projected(px, py, valid, ox, oy, geometry, radius):
    """:func:`match` on positions :func:`project_valid` gave (one projection serves
    several radii)."""
    where = np.flatnonzero(within(px, py, valid, geometry, radius))
    obs_idx, pos = nearest_matches(ox, oy, px[where], py[where], radius)
    return obs_idx, where[pos], where.shape[0]


@njit(cache=True)
def confirmed_count(obs_idx, hyp_obs, n_obs):
    """How many of the matched observed stars ``obs_idx`` are not among ``hyp_obs``."""
    chosen = np.zeros(n_obs, np.bool_)
    chosen[hyp_obs] = True
    count = 0
    for i in obs_idx:
        count += not chosen[i]
    return count


@njit(cache=True)
def first_match(obs_vectors, ox, oy, hyp_obs, hyp_sky, catalog, cone_order, cone_ra,
                cone_bands, cone_radius, geometry, radius, cos_radius):
    """The first test of a hypothesis, in one call: its attitude (Wahba), each of its
    stars within the match radius, then the catalog cone around that attitude matched to
    the frame. Returns (fits, matrix, cone rows, cone vectors, observed index, cone
    position, catalog stars in the image, matches outside the hypothesis)."""
    matrix = wahba(obs_vectors[hyp_obs], hyp_sky)
    rows = np.zeros(0, np.int64)
    vectors = np.zeros((0, 3))
    if not fits_within(obs_vectors[hyp_obs], hyp_sky, matrix, cos_radius):
        return False, matrix, rows, vectors, rows, rows, 0, 0
    rows = cone_rows(catalog, cone_order, cone_ra, cone_bands, matrix[:, 2].copy(),
                     cone_radius)
    vectors = np.empty((rows.shape[0], 3))
    for i in range(rows.shape[0]):
        vectors[i] = catalog[rows[i]]
    obs_idx, pos, n_in = match(vectors, matrix, ox, oy, geometry, radius)
    return (True, matrix, rows, vectors, obs_idx, pos, n_in,
            confirmed_count(obs_idx, hyp_obs, ox.shape[0]))


@njit(cache=True)
def first_match_fixed(obs_vectors, ox, oy, hyp_obs, hyp_sky, vectors, geometry, radius,
                      cos_radius):
    """:func:`first_match` over given catalog vectors instead of a cone: (fits, matrix,
    observed index, vector position, catalog stars in the image, matches outside)."""
    matrix = wahba(obs_vectors[hyp_obs], hyp_sky)
    none = np.zeros(0, np.int64)
    if not fits_within(obs_vectors[hyp_obs], hyp_sky, matrix, cos_radius):
        return False, matrix, none, none, 0, 0
    obs_idx, pos, n_in = match(vectors, matrix, ox, oy, geometry, radius)
    return True, matrix, obs_idx, pos, n_in, confirmed_count(obs_idx, hyp_obs, ox.shape[0])


@njit(cache=True)
def _same(obs_a, pos_a, obs_b, pos_b):
    """Whether two match lists are the same pairs in the same order."""
    if obs_a.shape[0] != obs_b.shape[0]:
        return False
    for k in range(obs_a.shape[0]):  # noqa: SIM110 (numba compiles no generator into all())
        if obs_a[k] != obs_b[k] or pos_a[k] != pos_b[k]:
            return False
    return True


@njit(cache=True)
def refine(obs_vectors, ox, oy, vectors, geometry, radius, capture, obs_m, pos_m,
           max_rounds):
    """Refit on every matched star and match again until the matched set stops changing;
    when a plain refit changes nothing, refit once on the matches within ``capture``
    match radii and keep that only if it then matches more stars (see
    :func:`startrack.verify._verification.refine`). Returns (observed index, vector position,
    matrix)."""
    obs_m, pos_m, matrix, _, _, _, _ = refine_projected(
        obs_vectors, ox, oy, vectors, geometry, radius, capture, obs_m, pos_m, max_rounds)
    return obs_m, pos_m, matrix


@njit(cache=True)
def refine_projected(obs_vectors, ox, oy, vectors, geometry, radius, capture, obs_m, pos_m,
                     max_rounds):
    """:func:`refine`, plus the vectors as :func:`project_valid` projects them at the
    returned matrix and whether that projection is there (it is when the refinement
    stopped because nothing changed; the labelling then need not project again)."""
    matrix = wahba(obs_vectors[obs_m], vectors[pos_m])
    px, py, valid = np.zeros(0), np.zeros(0), np.zeros(0, np.bool_)
    projected = False
    for _ in range(max_rounds):
        px, py, valid = project_valid(vectors, matrix, geometry)
        projected = True
        obs_new, pos_new, _ = match_projected(px, py, valid, ox, oy, geometry, radius)
        changed = obs_new.shape[0] > obs_m.shape[0] or (
            obs_new.shape[0] == obs_m.shape[0] and not _same(obs_new, pos_new, obs_m, pos_m))
        if not changed:
            obs_w, pos_w, _ = match_projected(px, py, valid, ox, oy, geometry,
                                              capture * radius)
            if obs_w.shape[0] < 2 or _same(obs_w, pos_w, obs_m, pos_m):
                break  # the same pairs refit to the same attitude: nothing would change
            wide = wahba(obs_vectors[obs_w], vectors[pos_w])
            obs_new, pos_new, _ = match(vectors, wide, ox, oy, geometry, radius)
            if obs_new.shape[0] <= obs_m.shape[0]:
                break
        obs_m, pos_m = obs_new, pos_new
        matrix = wahba(obs_vectors[obs_m], vectors[pos_m])
        projected = False
    return obs_m, pos_m, matrix, px, py, valid, projected


@njit(cache=True)
def project_refined(vectors, geometry, radius, matrix, px, py, valid, projected):
    """:func:`project` at a refined ``matrix`` with margin ``radius``, reusing the
    refinement's own projection when it has one (:func:`refine_projected`)."""
    if projected:
        return px, py, within(px, py, valid, geometry, radius)
    return project(vectors, matrix, geometry, radius)


@njit(cache=True)
def refine_and_label(obs_vectors, ox, oy, vectors, mags, geometry, radius, capture, obs_m,
                     pos_m, max_rounds, flux, has_flux, radius2, sigma0, area, gap,
                     log_false_odds, resolve2, mag_sigmas, min_mag_sigma, min_sigma_px,
                     min_fit):
    """An accepted hypothesis's matches refined (:func:`refine`), the stars labelled at the
    refined attitude (:func:`startrack.matching.labelling_kernels.label_kernel`, whose parameters
    follow ``max_rounds``) and the attitude refitted to the labels when there are three or
    more. Returns (observed index, vector position, refined matrix, final matrix)."""
    obs_m, pos_m, matrix, px, py, valid, projected = refine_projected(
        obs_vectors, ox, oy, vectors, geometry, radius, capture, obs_m, pos_m, max_rounds)
    px, py, inside = project_refined(vectors, geometry, radius, matrix, px, py, valid,
                                     projected)
    sel = np.flatnonzero(inside)
    obs_index, cat_pos, _, _, _, _ = label_kernel(
        ox, oy, px[sel], py[sel], mags[sel], sel, flux, has_flux, radius2, sigma0, area, gap,
        log_false_odds, resolve2, mag_sigmas, min_mag_sigma, min_sigma_px, min_fit)
    final = matrix
    if obs_index.shape[0] >= 3:
        final = wahba(obs_vectors[obs_index], vectors[cat_pos])
    return obs_index, cat_pos, matrix, final


@njit(cache=True)
def residual_angles(obs_vectors, obs_index, matrix, cat_vectors):
    """Angle (radians) between each observed star ``obs_vectors[obs_index[k]]`` rotated
    to the sky by ``matrix`` (camera to sky) and its catalog vector ``cat_vectors[k]``."""
    out = np.empty(obs_index.shape[0])
    for k in range(obs_index.shape[0]):
        v = obs_vectors[obs_index[k]]
        dot = 0.0
        for i in range(3):
            dot += (matrix[i, 0] * v[0] + matrix[i, 1] * v[1] + matrix[i, 2] * v[2]) \
                * cat_vectors[k, i]
        out[k] = math.acos(max(-1.0, min(1.0, dot)))
    return out


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a tiny input, so that the
    first frame is not timed with the compilation."""
    v = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.0]])
    v /= np.sqrt((v * v).sum(axis=1))[:, None]
    xy = np.array([1.0, 2.0, 3.0])
    geometry = np.array([100.0, 1.0, 1.0, 4.0, 4.0, 0.0, 0.0, 0.0, np.inf])
    m = wahba(v, v)
    fits_within(v, v, m, 0.5)
    idx = np.arange(3)
    refine(v, xy, xy, v, geometry, 1.0, 3.0, idx, idx, 2)
    refine_and_label(v, xy, xy, v, xy, geometry, 1.0, 3.0, idx, idx, 2, xy, True, 1.0, 1.0,
                     1e4, -6.9, -6.9, 4.0, 5.0, 0.03, 0.02, 5)
    matrix_to_quaternion(m)
    residual_angles(v, idx, m, v)
    from startrack.matching import check_kernels  # it imports this module

    check_kernels.warm_up()
