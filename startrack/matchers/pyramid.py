"""Pyramid (Mortari, Samaan, Bruccoleri, Junkins 2004): a triangle of pair lookups, confirmed
by a fourth star.

For star triples (i, j, k) in the paper's spreading order, the three sides are looked up
in the pair k-vector and joined into the catalog triangles consistent with all three; the
mirror image is rejected by the sign of the triple product (a rotation keeps it, a
reflection flips it). The surviving triangles are then tested together against every
fourth star r at once: the angles from r to i, j and k must all match the angles from one
catalog star R to the triangle's stars. The brightest r with 1 to ``max_pyramids``
pyramids gives the hypotheses (several: double stars closer than the noise); with three
stars only, a triangle that unique is.

Pattern stars (as tetra3 does): the triangles are looked up first among the catalog's
brighter stars only (``pattern_per_region``: stars with fewer brighter ones within half
the FOV), whose pair table is ~18x smaller on Hipparcos Hp <= 6.5 at 20 deg, so each lookup
at 1 px noise returns hundreds of pairs instead of tens of thousands. A frame's brightest
stars are pattern stars; the fourth star and the verification use the whole catalog, and
with ``fallback`` the full pair table is searched when no pattern-star hypothesis passed.
Because the triples are then cheap, up to ``extra_stars`` fainter stars join when bright
false stars spoil the brightest ``config.max_stars``.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import lru_cache

import numpy as np

from startrack.attitude import wahba_matrices
from startrack.database import StarDatabase
from startrack.matchers.angle import PairLookup, join_close, join_extend, smart_triples
from startrack.matchers.base import Matcher, MatcherConfig, register
from startrack.types import Hypothesis, MatchDiagnostics, Observation

# The fourth star's catalog candidates are searched within this many angle tolerances of
# where a triangle's attitude puts it: its three angles then pin it much closer.
CONFIRM_RADIUS = 3.0


def triple_products(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """a . (b x c) for rows of three (N x 3) arrays: positive for a counter-clockwise
    triangle seen from outside the sphere."""
    # Written out: np.cross costs tens of microseconds of overhead per call.
    return (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
            + a[:, 1] * (b[:, 2] * c[:, 0] - b[:, 0] * c[:, 2])
            + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))


@lru_cache(maxsize=64)
def triple_order(first: int, n: int, limit: int) -> tuple[tuple[int, int, int], ...]:
    """The triples tried, at most ``limit``: those of the ``first`` brightest stars in
    spreading order, then those that bring in the fainter stars up to ``n``."""
    triples = list(smart_triples(first))
    triples += [t for t in smart_triples(n) if t[2] >= first]
    return tuple(triples[:limit])


@register
class PyramidMatcher(Matcher):
    """Mortari's Pyramid on the shared pair database."""

    name = "pyramid"
    description = "triangle of pair lookups confirmed by a fourth star (Mortari et al. 2004)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_triples: int = 220, max_triangles: int = 500, max_pyramids: int = 4,
                 pattern_per_region: int | None = 15, region_radius_deg: float | None = None,
                 extra_stars: int = 4, fallback: bool = True) -> None:
        super().__init__(database, config)
        self.max_triples = int(max_triples)  # triples tried per frame and pair table
        self.max_triangles = int(max_triangles)  # more catalog triangles: triple skipped
        # More confirmed pyramids than this: ambiguous, try another fourth star. A few are
        # handed to verification, for double stars closer than the noise match either way.
        self.max_pyramids = int(max_pyramids)
        # Patterns are first looked up among the pattern stars only (fewer than
        # ``pattern_per_region`` brighter stars within ``region_radius_deg``): a frame's
        # brightest stars are pattern stars, and each lookup returns far fewer pairs. With
        # ``fallback`` the full pair table follows when no pattern-star hypothesis passed.
        self.pattern_per_region = None if pattern_per_region is None else int(pattern_per_region)
        self.region_radius_deg = region_radius_deg
        self.fallback = bool(fallback)
        # When the ``config.max_stars`` brightest fail (false stars crowd them), the triples
        # with up to this many fainter stars are tried next.
        self.extra_stars = int(extra_stars)

    def prepare(self) -> None:
        super().prepare()
        self._tables()

    def _tables(self) -> list:
        tables = [self.database.pattern_pairs(self.pattern_per_region, self.region_radius_deg)]
        if self.pattern_per_region is not None and self.fallback:
            tables.append(self.database.pairs)
        return tables

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars + max(self.extra_stars, 0), len(obs))
        if n < 3:
            return
        vec = obs.vectors[:n]
        tol = self.angle_tolerance(obs)
        triples = triple_order(min(self.config.max_stars, n), n, self.max_triples)
        for fallback, table in enumerate(self._tables()):
            diag.extra["fallback"] = bool(fallback)
            lookup = PairLookup(table, vec, tol, len(self.database.vectors), diag)
            yield from self._search(lookup, vec, tol, triples, diag)

    def _search(self, lookup: PairLookup, vec: np.ndarray, tol: float, triples: tuple,
                diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = len(vec)
        for i, j, k in triples:
            diag.extra["triples"] = diag.extra.get("triples", 0) + 1
            tri = self._triangles(lookup, vec, tol, (i, j, k), diag)
            if len(tri) == 0 or len(tri) > self.max_triangles:
                continue
            if n == 3:
                if len(tri) <= self.max_pyramids:
                    for row in tri:
                        yield Hypothesis(np.array([i, j, k]), row.astype(np.int64))
                continue
            r, pyr = self._confirm(vec, lookup.angles, tri, (i, j, k), tol, diag)
            for row in pyr:
                yield Hypothesis(np.array([i, j, k, r]), row)

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
        sides = np.sin(lookup.angles[[j, i, i], [k, k, j]]).sum()  # |b x c| per side
        if abs(observed) <= tol * sides:
            return tri
        cat = self.database.vectors
        signs = triple_products(cat[tri[:, 0]], cat[tri[:, 1]], cat[tri[:, 2]])
        return tri[np.sign(signs) == np.sign(observed)]

    def _confirm(self, vec: np.ndarray, angles: np.ndarray, tri: np.ndarray,
                 ijk: tuple[int, int, int], tol: float,
                 diag: MatchDiagnostics) -> tuple[int, np.ndarray]:
        """The brightest fourth star r that confirms 1 to ``max_pyramids`` pyramids
        (I, J, K, R): catalog stars R whose angles to I, J and K all lie within ``tol`` of
        the observed angles from r to i, j and k. Returns (r, pyramids as rows), or
        (-1, no rows).

        Every triangle and every fourth star at once: each triangle's attitude puts r on
        the sky, and only catalog stars near that spot can meet three angles to a
        non-degenerate triangle, so they are found with the catalog's k-d tree rather than
        with three pair lookups; the angle test itself is the paper's.
        """
        others = np.array([r for r in range(len(vec)) if r not in ijk])
        none = -1, np.zeros((0, 4), np.int64)
        if len(others) == 0:
            return none
        diag.pivots += 3 * len(others)
        cat = self.database.vectors
        rot = wahba_matrices(vec[list(ijk)], cat[tri])  # (t, 3, 3) camera -> sky
        predicted = np.einsum("tab,rb->tra", rot, vec[others])
        near = self.database.nearest(predicted, CONFIRM_RADIUS * tol, self.max_pyramids + 1)
        ok = near >= 0
        star = np.where(ok, near, 0)
        for col, s in enumerate(ijk):
            cos = np.einsum("trqa,ta->trq", cat[star], cat[tri[:, col]])
            err = np.arccos(np.clip(cos, -1.0, 1.0)) - angles[s, others][None, :, None]
            ok &= (np.abs(err) <= tol) & (star != tri[:, col][:, None, None])
        counts = ok.sum(axis=(0, 2))
        good = np.flatnonzero((counts >= 1) & (counts <= self.max_pyramids))
        if len(good) == 0:
            return none
        m = int(good[0])
        t, q = np.nonzero(ok[:, m, :])
        return int(others[m]), np.column_stack([tri[t], star[t, m, q]]).astype(np.int64)
