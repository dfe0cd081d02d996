"""Pyramid (Mortari, Samaan, Bruccoleri, Junkins 2004): a triangle of pair lookups, confirmed
by a fourth star.

For star triples (i, j, k) in the paper's spreading order, the three sides are looked up
in the pair k-vector and joined into the catalog triangles consistent with all three; the
mirror image is rejected by the sign of the triple product (a rotation keeps it, a
reflection flips it). The surviving triangles are then tested together against a fourth
star r: its three pairs (i, r), (j, r), (k, r) must all be candidate pairs with one
catalog star R. A unique pyramid is the hypothesis; with three stars only, a unique
triangle is. On a dense catalog (Hipparcos to 6.5 in a 20 deg field at 0.3 px noise) a
triangle alone is rarely unique, tens of catalog triangles fit; so up to
``max_triangles`` go to the fourth-star test together, and up to ``max_pyramids``
surviving pyramids (double stars closer than the noise) go to verification.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from startrack.database import StarDatabase
from startrack.matchers.angle import PairLookup, join_close, join_extend, smart_triples
from startrack.matchers.base import (
    Hypothesis,
    MatchDiagnostics,
    Matcher,
    MatcherConfig,
    Observation,
    register,
)


def triple_products(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """a . (b x c) for rows of three (N x 3) arrays: positive for a counter-clockwise
    triangle seen from outside the sphere."""
    return np.einsum("ij,ij->i", a, np.cross(b, c))


@register
class PyramidMatcher(Matcher):
    """Mortari's Pyramid on the shared pair database."""

    name = "pyramid"
    description = "triangle of pair lookups confirmed by a fourth star (Mortari et al. 2004)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_triples: int = 60, max_triangles: int = 500,
                 max_pyramids: int = 4) -> None:
        super().__init__(database, config)
        self.max_triples = int(max_triples)  # triples tried per frame
        self.max_triangles = int(max_triangles)  # more catalog triangles: triple skipped
        # More confirmed pyramids than this: ambiguous, try another fourth star. A few are
        # handed to verification, for double stars closer than the noise match either way.
        self.max_pyramids = int(max_pyramids)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        vec = obs.vectors[:n]
        tol = self.angle_tolerance(obs)
        lookup = PairLookup(self.database.pairs, vec, tol, len(self.database.vectors), diag)
        for tried, (i, j, k) in enumerate(smart_triples(n)):
            if tried >= self.max_triples:
                break
            diag.extra["triples"] = tried + 1
            tri = self._triangles(lookup, vec, tol, (i, j, k), diag)
            if len(tri) == 0 or len(tri) > self.max_triangles:
                continue
            if n == 3:
                if len(tri) <= self.max_pyramids:
                    for row in tri:
                        yield Hypothesis(np.array([i, j, k]), row.astype(np.int64))
                continue
            for r in range(n):
                if r in (i, j, k):
                    continue
                pyr = self._confirm(lookup, tri, (i, j, k), r, diag)
                if len(pyr) == 0:
                    continue  # r is a false star, or the triangle is wrong
                if len(pyr) > self.max_pyramids:
                    continue
                for row in pyr:
                    yield Hypothesis(np.array([i, j, k, r]), row.astype(np.int64))
                break

    def _triangles(self, lookup: PairLookup, vec: np.ndarray, tol: float,
                   ijk: tuple[int, int, int], diag: MatchDiagnostics) -> np.ndarray:
        """Catalog triangles (rows I, J, K) whose three sides match, mirror images removed."""
        i, j, k = ijk
        side = lookup(i, j)
        tri = join_extend(np.column_stack([side.cp, side.cq]), 1, lookup(j, k))
        tri = join_close(tri, 0, 2, lookup(i, k))
        diag.extra["triangles"] = diag.extra.get("triangles", 0) + len(tri)
        if len(tri) == 0:
            return tri
        observed = float(triple_products(vec[[i]], vec[[j]], vec[[k]])[0])
        # A nearly flat triangle's sign is within the noise: keep both handednesses then.
        sides = np.linalg.norm(np.cross(vec[[j, i, i]], vec[[k, k, j]]), axis=1).sum()
        if abs(observed) <= tol * sides:
            return tri
        cat = self.database.vectors
        signs = triple_products(cat[tri[:, 0]], cat[tri[:, 1]], cat[tri[:, 2]])
        return tri[np.sign(signs) == np.sign(observed)]

    @staticmethod
    def _confirm(lookup: PairLookup, tri: np.ndarray, ijk: tuple[int, int, int], r: int,
                 diag: MatchDiagnostics) -> np.ndarray:
        """Pyramids (I, J, K, R): the triangles extended by a catalog star R whose pairs with
        I, J and K all match the observed pairs to star r."""
        i, j, k = ijk
        diag.pivots += 3
        pyr = join_extend(tri, 0, lookup(i, r))
        pyr = join_close(pyr, 1, 3, lookup(j, r))
        return join_close(pyr, 2, 3, lookup(k, r))
