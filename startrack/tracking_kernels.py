"""Compiled kernels of the tracking stage: pair observed stars with the catalog stars
projected at a prediction, vote on their displacement, and the whole tracked attempt in
one call (numba; a frame has tens of stars, and numpy or scipy on so few is dominated by
per-call overhead). Projection, first test, refinement and labelling are verification's
own (:mod:`startrack.matching.verify_kernels`), lens included.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching import verify_kernels
from startrack.matching.check_kernels import binomial_tail
from startrack.matching.labelling_kernels import warm_up as _warm_up_labelling
from startrack.matching.nearest_kernels import pairs_within
from startrack.matching.verify_kernels import project

# The fields of the attempt kernel's ``scan`` array, in order (built by
# :meth:`startrack.tracking._track.CatalogCone.setup`; see :func:`attempt`).
N_SCAN = 17
(S_WINDOW, S_KEEP, S_VOTE_RADII, S_RADIUS, S_CAPTURE, S_COS_RADIUS, S_MAX_STARS, S_ROUNDS,
 S_MIN_CONFIRMED, S_MAX_HYPOTHESES, S_PAIRS, S_MAX_FALSE, S_AREA, S_HALF_SIDE,
 S_SETTLE_MISSES, S_VOTE_CENTRES, S_CONE_REUSE) = range(N_SCAN)


@njit(cache=True)
def window_pairs(vectors, matrix, ox, oy, geometry, window):
    """Every (observed, catalog position) pair within ``window`` pixels at ``matrix``,
    by observed then catalog position, with the displacement catalog - observed."""
    px, py, inside = project(vectors, matrix, geometry, window)
    sel = np.flatnonzero(inside)
    oi, pos, _, _ = pairs_within(ox, oy, px[sel], py[sel], window * window)
    cj = sel[pos]
    dx = np.empty(oi.shape[0])
    dy = np.empty(oi.shape[0])
    for k in range(oi.shape[0]):
        dx[k], dy[k] = px[cj[k]] - ox[oi[k]], py[cj[k]] - oy[oi[k]]
    return oi, cj, dx, dy


@njit(cache=True)
def consistent(oi, ci, dx, dy, vote_tol, tol, centres):
    """Indices of the pairs that agree on one displacement: among the pairs of the
    ``centres`` brightest observed stars, the one whose displacement the most distinct
    observed stars share within ``vote_tol`` px (the densest spot; ties: the smaller
    displacement), then, within ``tol`` px of it (which allows for the spread a roll error
    makes), per observed star the pair nearest it, each catalog star once (nearest wins,
    ties: the lower observed index). Sorted by the distance of their displacement from
    the winner's."""
    p = oi.shape[0]
    v2 = vote_tol * vote_tol
    t2 = tol * tol
    seen = np.full(oi.max() + 1 if p else 1, -1, np.int64)
    best, best_votes, best_d = -1, -1, np.inf
    # The true displacement is shared by nearly every real star's pair, so the brightest
    # stars' pairs hold it: trying only those as centres bounds the vote at O(centres p).
    for i in range(p):
        if oi[i] >= centres:
            break
        votes = 0
        for j in range(p):
            if (dx[i] - dx[j]) ** 2 + (dy[i] - dy[j]) ** 2 <= v2 and seen[oi[j]] != i:
                seen[oi[j]] = i
                votes += 1
        d = dx[i] ** 2 + dy[i] ** 2
        if votes > best_votes or (votes == best_votes and d < best_d):
            best, best_votes, best_d = i, votes, d
    n_obs = seen.shape[0]
    pick = np.full(n_obs, -1, np.int64)
    dist = np.full(n_obs, np.inf)
    if best < 0:
        return pick[:0]
    for j in range(p):
        d = (dx[best] - dx[j]) ** 2 + (dy[best] - dy[j]) ** 2
        if d <= t2 and d < dist[oi[j]]:
            pick[oi[j]], dist[oi[j]] = j, d
    keep = np.zeros(n_obs, np.bool_)
    owner = np.full(ci.max() + 1, -1, np.int64)  # per catalog star, the observed one kept
    for o in range(n_obs):
        if pick[o] < 0:
            continue
        c = ci[pick[o]]
        if owner[c] < 0 or dist[o] < dist[owner[c]]:  # the nearer keeps it; ties: earlier
            if owner[c] >= 0:
                keep[owner[c]] = False
            owner[c], keep[o] = o, True
    chosen = pick[keep]
    # Nearest the winning displacement first: true pairs cluster there, chance pairs
    # inside a wide window spread over it.
    return chosen[np.argsort(dist[keep], kind="mergesort")]


@njit(cache=True)
def consistent_pairs(vectors, matrix, ox, oy, geometry, window, vote_tol, tol, centres):
    """:func:`window_pairs` then :func:`consistent` in one call: the consistent pairs'
    observed indices and catalog positions, and how many pairs the window held (the
    vote needs three)."""
    oi, cj, dx, dy = window_pairs(vectors, matrix, ox, oy, geometry, window)
    if oi.shape[0] < 3:
        return oi[:0], cj[:0], oi.shape[0]
    keep = consistent(oi, cj, dx, dy, vote_tol, tol, centres)
    return oi[keep], cj[keep], oi.shape[0]


@njit(cache=True)
def _triples(n, limit):
    """The first ``limit`` index triples of ``range(n)`` in itertools.combinations order."""
    out = np.empty((max(limit, 0), 3), np.int64)
    h = 0
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                if h == limit:
                    return out
                out[h, 0], out[h, 1], out[h, 2] = a, b, c
                h += 1
    return out[:h]


@njit(cache=True)
def near(a, b, min_trace):
    """Whether attitudes ``a`` and ``b`` differ by at most the angle whose
    ``1 + 2 cos`` is ``min_trace`` (the trace of a^T b)."""
    t = 0.0
    for i in range(3):
        for j in range(3):
            t += a[i, j] * b[i, j]
    return t >= min_trace


@njit(cache=True)
def nearby(vectors, matrix, geometry, margin):
    """Positions of the vectors in the image widened by ``margin`` px at ``matrix``, and
    of any the lens model cannot place there (beyond its fold radius: kept, since a turn
    could bring them in)."""
    _, _, inside = project(vectors, matrix, geometry, margin)
    if math.isfinite(geometry[8]):
        for i in range(vectors.shape[0]):
            v = vectors[i]
            vx = v[0] * matrix[0, 0] + v[1] * matrix[1, 0] + v[2] * matrix[2, 0]
            vy = v[0] * matrix[0, 1] + v[1] * matrix[1, 1] + v[2] * matrix[2, 1]
            vz = v[0] * matrix[0, 2] + v[1] * matrix[1, 2] + v[2] * matrix[2, 2]
            inside[i] |= vz > 1e-12 and not (vx * vx + vy * vy) / (vz * vz) < geometry[8]
    return np.flatnonzero(inside)


@njit(cache=True)
def _settle(obs_vectors, ox, oy, vectors, mags, geometry, scan, flux, has_flux, label,
            min_fit, oi, obs_m, pos_m):
    """An accepted hypothesis refined and labelled. When the hypothesis's attitude already
    matched the observed star of every consistent pair (bar ``scan[S_SETTLE_MISSES]`` of
    them), those pairs spanning the frame, the matches' own fit is labelled at once: that is where
    verification's refinement stops when its first refit changes no match. Else its
    iterative refinement runs. Returns (observed index, vector position, refined, final)."""
    matched = np.zeros(ox.shape[0], np.bool_)
    matched[obs_m] = True
    missed = 0
    for o in oi:
        missed += not matched[o]
    rounds = 0 if missed <= scan[S_SETTLE_MISSES] else int(scan[S_ROUNDS])
    return verify_kernels.refine_and_label(
        obs_vectors, ox, oy, vectors, mags, geometry, scan[S_RADIUS], scan[S_CAPTURE], obs_m,
        pos_m, rounds,
        flux, has_flux, label[0], label[1], label[2], label[3], label[4], label[5],
        label[6], label[7], label[8], min_fit)


@njit(cache=True)
def covers(cone_matrix, cone_turn, prior, turn, reuse):
    """Whether rows held for attitudes within ``cone_turn`` of ``cone_matrix`` cover those
    within ``turn`` of ``prior`` (rotation angles add up), and are not far wider."""
    spare = cone_turn - turn
    return 0.0 <= spare <= 2.0 * reuse and near(cone_matrix, prior,
                                                  1.0 + 2.0 * math.cos(spare))


@njit(cache=True)
def attempt(vectors, mags, rows, cone_matrix, cone_turn, obs_vectors, ox, oy, geometry,
            prior, sigma, scan, flux, has_flux, label, min_fit, start):
    """One tracked frame in one call: the consistent pairs at the prediction ``prior``
    (1-sigma ``sigma`` rad; :func:`consistent_pairs`), then its three-star hypotheses from
    number ``start`` on, each through verification's own first test
    (:func:`~startrack.matching.verify_kernels.first_match_fixed`) and its false-match
    bound (verification's own compiled
    :func:`~startrack.matching.check_kernels.binomial_tail`); the first accepted is
    refined and labelled (:func:`_settle`). An attitude turned from ``prior`` by more
    than the turn that moves a star at the image's edge across the window is not taken
    (a wider one would have left the pairs it came from outside the window): the catalog
    ``rows`` (vectors, magnitudes) hold every star that can reach the image within
    ``cone_turn`` of ``cone_matrix`` (:class:`startrack.tracking._track.CatalogCone`).

    ``scan`` (:meth:`startrack.tracking._track.CatalogCone.setup`): window px per sigma, keep
    tolerance px per sigma, vote radii, match radius (px), capture (radii), cos of the
    match radius, brightest stars paired, refinement rounds, confirmed stars needed,
    hypotheses at most, pairs they are drawn from, bound on a false match, the area
    factor of its p (pi / (width height)), half the image's shorter side (px), consistent
    pairs unmatched and still settled in one pass (:func:`_settle`), vote centres, the
    cone's spare turn. ``label``: :func:`startrack.verify._labelling.kernel_params`'s floats
    (``radius2`` to ``min_sigma_px``).

    Returns (status: 0 none accepted, 1 accepted, 3 the refined attitude left the allowed
    turn, 4 the rows
    do not cover the allowed turn (the caller looks them up again); hypothesis number;
    tried; pairs in the window; confirmed; catalog stars in the image; bound; observed
    index; catalog rows; attitude).
    """
    r = scan[S_RADIUS]
    window, tol = scan[S_WINDOW] * sigma + r, scan[S_KEEP] * sigma + r
    turn = window / scan[S_HALF_SIDE]
    none = np.zeros(0, np.int64)
    if not covers(cone_matrix, cone_turn, prior, turn, scan[S_CONE_REUSE]):
        return 4, -1, 0, 0, 0, 0, 1.0, none, none, prior
    turn_trace = 1.0 + 2.0 * math.cos(min(turn, math.pi))
    m = min(ox.shape[0], int(scan[S_MAX_STARS]))
    oi, cj, n_pairs = consistent_pairs(vectors, prior, ox[:m], oy[:m], geometry, window,
                                       min(tol, scan[S_VOTE_RADII] * r), tol,
                                       int(scan[S_VOTE_CENTRES]))
    triples = _triples(min(oi.shape[0], int(scan[S_PAIRS])), int(scan[S_MAX_HYPOTHESES]))
    tried = 0
    for h in range(start, triples.shape[0]):
        tried += 1
        fits, matrix, obs_m, pos, n_in, confirmed = verify_kernels.first_match_fixed(
            obs_vectors, ox, oy, oi[triples[h]], vectors[cj[triples[h]]], vectors,
            geometry, r, scan[S_COS_RADIUS])
        if not fits or not near(matrix, prior, turn_trace) \
                or confirmed < int(scan[S_MIN_CONFIRMED]):
            continue
        prob = binomial_tail(confirmed - 1, ox.shape[0] - 3,
                             min(1.0, n_in * r * r * scan[S_AREA]))
        if prob > scan[S_MAX_FALSE]:
            continue
        obs_i, pos_i, refined, final = _settle(obs_vectors, ox, oy, vectors, mags, geometry,
                                               scan, flux, has_flux, label, min_fit, oi,
                                               obs_m, pos)
        status = 1 if near(refined, prior, turn_trace) else 3
        return status, h, tried, n_pairs, confirmed, n_in, prob, obs_i, rows[pos_i], final
    return 0, -1, tried, n_pairs, 0, 0, 1.0, none, none, prior


def warm_up_args() -> tuple:
    """A tiny tracked frame as the attempt kernels take it (``start`` aside): three stars,
    held rows, prior, ``scan`` and labelling floats; for compiling them before timing."""
    v = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.0]])
    v /= np.sqrt((v * v).sum(axis=1))[:, None]
    m, xy = np.eye(3), np.array([1.0, 2.0, 3.0])
    geometry = np.array([100.0, 1.0, 1.0, 4.0, 4.0, 0.0, 0.0, 0.0, np.inf])
    scan = np.array([1e4, 1e4, 3.0, 1.0, 3.0, 0.9, 64, 5, 2, 24, 12, 1e-9, 1e-4, 2.0, 2.9,
                     24, 0.01])
    label = np.array([1.0, 1.0, 1e4, -6.9, -6.9, 4.0, 5.0, 0.03, 0.02])
    return (v, xy, np.arange(3), m, 0.01, v, xy, xy, geometry, m, 1e-4, scan, xy, True,
            label, 5)


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a tiny input, so that the first
    frame of a sequence is not timed with the compilation."""
    args = warm_up_args()
    v, xy, m, geometry = args[0], args[1], args[3], args[8]
    verify_kernels.warm_up()
    oi, cj, dx, dy = window_pairs(v, m, xy, xy, geometry, 50.0)
    consistent(oi, cj, dx, dy, 1.0, 2.0, 24)
    consistent_pairs(v, m, xy, xy, geometry, 50.0, 1.0, 2.0, 24)
    attempt(*args, 0)
    nearby(v, m, geometry, 9.0)
    _warm_up_labelling()  # a tracked frame's labelling
