"""Planar-triangle matcher (Cole and Crassidis, 2006): area and polar moment, with pivoting.

Each triangle of bright observed stars is looked up in the catalog triangle table by area
(k-vector, A +- k sigma_A) and filtered by polar moment (J +- k sigma_J), the sigmas
propagated from the centroid noise. The catalog vertices are mapped to the observed ones
by comparing the three side lengths, and the mirror image is refused (triple product).
While several catalog triangles remain, the matcher pivots on a triangle that shares two
stars with the last one and keeps the hypotheses in which the shared stars agree.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from functools import cache

import numpy as np

from startrack.database import StarDatabase
from startrack.matchers.base import Matcher, MatcherConfig, register, register_variant
from startrack.matching.features import feature_sigma, observed_features
from startrack.matching.geometry import handedness
from startrack.matching.pairs import join_sorted
from startrack.matching.triples import brightness_triples
from startrack.types import Hypothesis, MatchDiagnostics, Observation

# The six vertex orders; the odd ones reverse the handedness (the triple product's sign).
_PERMS = np.array(list(itertools.permutations(range(3))))
_ODD = np.array([False, True, True, False, False, True])


def map_vertices(obs_tri: np.ndarray, cat_vectors: np.ndarray, side_tol: float,
                 check_mirror: bool) -> tuple[np.ndarray, np.ndarray]:
    """Vertex correspondences between one observed triangle (3 x 3) and catalog triangles
    (M x 3 x 3): for each of the six vertex orders whose sides all agree within
    ``side_tol`` (and, if ``check_mirror``, whose handedness agrees), the candidate index
    and the order. Returns (candidate, perm) arrays, best side agreement first."""
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


@register
class PlanarTriangleMatcher(Matcher):
    """Cole and Crassidis (2006): triangle area and polar moment, pivoting on shared sides."""

    name = "triangle"
    tables = ("triangles",)
    description = "planar triangles (area + polar moment, k-vector), pivoting"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_ambiguous: int = 5, min_stars: int = 4) -> None:
        super().__init__(database, config)
        self.max_ambiguous = max_ambiguous  # hypotheses yielded when pivots run out
        # Pivot at least once even when the first triangle is unique: a fourth star costs
        # one lookup, removes most chance matches, and a hypothesis spread over more of the
        # frame gives verification a better first attitude.
        self.min_stars = min_stars

    def _lookup(self, obs_tri: np.ndarray, features: tuple[float, ...], sigma: float,
                diag: MatchDiagnostics) -> np.ndarray:
        """Catalog rows (K x 3) matching the observed triangle, in its vertex order."""
        k = self.config.tolerance_sigma
        area, polar, s_area, s_polar = features
        table = self.database.triangles
        idx, n_area = table.query(area - k * s_area, area + k * s_area,
                                  polar - k * s_polar, polar + k * s_polar)
        diag.candidates += n_area
        diag.extra["polar_kept"] = diag.extra.get("polar_kept", 0) + len(idx)
        rows = table.rows[idx]
        side_tol = k * np.sqrt(2.0) * sigma
        cand, perm = map_vertices(obs_tri, self.database.vectors[rows], side_tol,
                                  check_mirror=area > k * s_area)
        return np.take_along_axis(rows[cand], _PERMS[perm], axis=1).astype(np.int64)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        vec = obs.vectors[:n]
        sigma = feature_sigma(obs, self.config.tolerance_sigma, self.config.min_tolerance_rad)
        triples = brightness_triples(n)
        feats = observed_features(vec, triples, sigma)

        @cache
        def lookup(a: int, b: int, c: int) -> np.ndarray:
            # Area, moment and their sigmas do not depend on the vertex order.
            return self._lookup(vec[[a, b, c]], feats[tuple(sorted((a, b, c)))], sigma, diag)

        for a, b, c in triples:
            hyps = lookup(a, b, c)
            if len(hyps) == 0:
                continue  # a false star, or a star outside the pattern set
            stars, last = [a, b, c], (a, b, c)
            while len(hyps) > 1 or len(stars) < self.min_stars:
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
                    break  # stars ran out: the survivors go to verification
            for row in hyps[: self.max_ambiguous]:
                yield Hypothesis(np.array(stars), row)


register_variant(PlanarTriangleMatcher, "triangle_nopivot",
                 "planar triangles, no forced pivot on a unique triangle (variant)", min_stars=3)
