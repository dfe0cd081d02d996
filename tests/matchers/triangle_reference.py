"""The triangle matcher's search as it ran in numpy and Python before it was compiled
(startrack._core.matchers.triangles): the lookups and vertex mapping in numpy, the pivots
through startrack.matchers._shared.pair_joins.join_sorted. Kept as the reference that
tests/matchers/test_triangle_search.py holds the compiled search to: the same hypotheses in the
same order, the same diagnostics."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from functools import cache

import numpy as np

from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._planar_triangle import PlanarTriangleMatcher
from startrack.matchers._shared.features import feature_sigma, observed_features
from startrack.matchers._shared.geometry import handedness
from startrack.matchers._shared.pair_joins import join_sorted
from startrack.matchers._shared.triples import brightness_triples

_PERMS = np.array(list(itertools.permutations(range(3))))
_ODD = np.array([False, True, True, False, False, True])


def map_vertices(obs_tri: np.ndarray, cat_vectors: np.ndarray, side_tol: float,
                 check_mirror: bool) -> tuple[np.ndarray, np.ndarray]:
    """The numpy vertex mapping (see startrack._core.matchers.triangles.map_vertices)."""
    o = obs_tri
    obs_sides = np.array([np.linalg.norm(o[0] - o[1]), np.linalg.norm(o[1] - o[2]),
                          np.linalg.norm(o[0] - o[2])])
    obs_hand = handedness(o[0], o[1], o[2])
    cat_hand = handedness(cat_vectors[:, 0], cat_vectors[:, 1], cat_vectors[:, 2])
    cands, perms, errs = [], [], []
    for k, p in enumerate(_PERMS):
        c = cat_vectors[:, p]
        sides = np.column_stack([np.linalg.norm(c[:, 0] - c[:, 1], axis=1),
                                 np.linalg.norm(c[:, 1] - c[:, 2], axis=1),
                                 np.linalg.norm(c[:, 0] - c[:, 2], axis=1)])
        err = np.max(np.abs(sides - obs_sides), axis=1)
        ok = err <= side_tol
        if check_mirror:
            ok &= (cat_hand * (-1.0 if _ODD[k] else 1.0)) == obs_hand
        idx = np.flatnonzero(ok)
        cands.append(idx)
        perms.append(np.full(len(idx), k))
        errs.append(err[idx])
    cand, perm, err = (np.concatenate(x) for x in (cands, perms, errs))
    order = np.argsort(err, kind="stable")
    return cand[order], perm[order]


def _lookup(m: PlanarTriangleMatcher, obs_tri: np.ndarray, features: tuple[float, ...],
            sigma: float, diag: MatchDiagnostics) -> np.ndarray:
    k = m.config.tolerance_sigma
    area, polar, s_area, s_polar = features
    table = m.database.triangles
    idx, n_area = table.query(area - k * s_area, area + k * s_area,
                              polar - k * s_polar, polar + k * s_polar)
    diag.candidates += n_area
    diag.extra["polar_kept"] = diag.extra.get("polar_kept", 0) + len(idx)
    diag.extra["lookups"] = diag.extra.get("lookups", 0) + 1
    rows = table.rows[idx]
    side_tol = k * np.sqrt(2.0) * sigma
    cand, perm = map_vertices(obs_tri, m.database.vectors[rows], side_tol,
                              check_mirror=area > k * s_area)
    return np.take_along_axis(rows[cand], _PERMS[perm], axis=1).astype(np.int64)


def reference_hypotheses(m: PlanarTriangleMatcher, obs: Observation,
                         diag: MatchDiagnostics) -> Iterator[Hypothesis]:
    """``m.hypotheses(obs, diag)`` as the Python search gave them."""
    n = min(m.config.max_stars, len(obs))
    if n < 3:
        return
    vec = obs.vectors[:n]
    sigma = feature_sigma(obs, m.config.tolerance_sigma, m.config.min_tolerance_rad)
    triples = brightness_triples(n)
    feats = observed_features(vec, triples, sigma)

    @cache
    def lookup(a: int, b: int, c: int) -> np.ndarray:
        return _lookup(m, vec[[a, b, c]], feats[tuple(sorted((a, b, c)))], sigma, diag)

    for a, b, c in triples:
        hyps = lookup(a, b, c)
        if len(hyps) == 0:
            continue
        stars, last = [a, b, c], (a, b, c)
        while len(hyps) > 1 or len(stars) < m.min_stars:
            p, q = last[1], last[2]
            for extra in (s for s in range(n) if s not in stars):
                diag.pivots += 1
                joined = join_sorted(hyps, (stars.index(p), stars.index(q)),
                                     lookup(p, q, extra))
                if len(joined):
                    hyps, last = joined, (p, q, extra)
                    stars.append(extra)
                    break
            else:
                break
        for row in hyps[: m.max_ambiguous]:
            yield Hypothesis(np.array(stars), row)
