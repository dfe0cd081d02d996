"""Planar-triangle matcher (Cole and Crassidis, 2006): area and polar moment, with pivoting.

Each triangle of bright observed stars is looked up in the catalog triangle table by area
(k-vector, A +- k sigma_A) and filtered by polar moment (J +- k sigma_J), the sigmas
propagated from the centroid noise. The catalog vertices are mapped to the observed ones
by comparing the three side lengths, and the mirror image is refused (triple product).
While several catalog triangles remain, the matcher pivots on a triangle that shares two
stars with the last one and keeps the hypotheses in which the shared stars agree.

The 2011 paper (Sedaghat, Toloei, Ghanbarpoor) pivots instead on triangles that share two
stars with the *first* triangle (``pivot_first=True``), only while more than one answer is
left, and calls a search that runs out of stars indeterminate: the variant
``triangle_first``. Its "binary test tree" (to cut the combinations of three tests) is
named in one sentence, with no structure given, so it is not built here: the k-vector
range on area, the polar-moment filter and the sorted join do that job.

The lookups, the vertex mapping and the pivot joins run compiled
(:class:`startrack._core.matchers.triangles.TriangleSearch`), returning at each triple that leaves
an answer so that verification's first acceptance ends the search.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import cache

import numpy as np

from startrack._core.matchers.triangles import SearchBuffers, TriangleCatalog, TriangleSearch
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import Matcher, MatcherConfig, register, register_variant
from startrack.matchers._shared.features import feature_sigma
from startrack.matchers._shared.triples import brightness_triples

# Search buffers larger than this (grown on a pathological frame) are not kept for the next.
_KEEP_BYTES = 1 << 27


@cache
def _triples(n: int) -> np.ndarray:
    return np.array(brightness_triples(n), np.int64).reshape(-1, 3)


@register
class PlanarTriangleMatcher(Matcher):
    """Cole and Crassidis (2006): triangle area and polar moment, pivoting on shared sides."""

    name = "triangle"
    tables = ("triangles",)
    description = "planar triangles (area + polar moment, k-vector), pivoting"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_ambiguous: int = 5, min_stars: int = 4,
                 pivot_first: bool = False) -> None:
        super().__init__(database, config)
        self.max_ambiguous = max_ambiguous  # hypotheses yielded when pivots run out
        # Every pivot triangle shares two stars with the first triangle (the paper), not
        # with the last one (ours: a chain that spreads over the frame).
        self.pivot_first = bool(pivot_first)
        # Pivot at least once even when the first triangle is unique: a fourth star costs
        # one lookup, removes most chance matches, and a hypothesis spread over more of the
        # frame gives verification a better first attitude.
        self.min_stars = min_stars
        self._buffers: list[SearchBuffers] = []  # the searches' memo memory

    def _catalog(self) -> TriangleCatalog:
        """The triangle table as the compiled search reads it."""
        table = self.database.triangles
        cache_ = table.__dict__.setdefault("_search_arrays", {})
        if "t" not in cache_:  # kept on the (frozen) table: lives and dies with it
            cache_["t"] = TriangleCatalog(table, self.database.vectors)
        return cache_["t"]

    def prepare(self) -> None:
        super().prepare()
        self._catalog()

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        k = self.config.tolerance_sigma
        sigma = feature_sigma(obs, k, self.config.min_tolerance_rad)
        triples = _triples(n)
        # A generator still running elsewhere keeps its buffers: this one takes others.
        search = TriangleSearch(self._catalog(), obs.vectors[:n], triples, k,
                                k * np.sqrt(2.0) * sigma, sigma, self._spare_buffers())
        try:
            yield from self._search(search, len(triples), diag)
        finally:
            if search.buffers.nbytes <= _KEEP_BYTES:
                self._buffers.append(search.buffers)

    def _spare_buffers(self) -> SearchBuffers | None:
        try:  # pop() alone: another thread may take the last one between a test and it
            return self._buffers.pop()
        except IndexError:
            return None

    def _search(self, search: TriangleSearch, n_triples: int,
                diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """The compiled search's answers, with its counters in ``diag``."""
        base = (diag.candidates, diag.pivots, diag.extra.get("polar_kept", 0),
                diag.extra.get("lookups", 0))
        t = 0
        while t < n_triples:
            t, stars, rows = search.next_answer(t, self.min_stars, self.max_ambiguous,
                                                 self.pivot_first)
            diag.candidates = base[0] + search.candidates
            diag.pivots = base[1] + search.pivots
            if search.lookups:
                # per lookup: area-window candidates (``candidates``), the polar filter's
                diag.extra["polar_kept"] = base[2] + search.polar_kept
                diag.extra["lookups"] = base[3] + search.lookups
            for row in rows if t < n_triples else ():
                yield Hypothesis(stars.copy(), row)
            t += 1


register_variant(PlanarTriangleMatcher, "triangle_nopivot",
                 "planar triangles, no forced pivot on a unique triangle (variant)", min_stars=3)
register_variant(PlanarTriangleMatcher, "triangle_first",
                 "planar triangles pivoting on the first triangle, one answer or none "
                 "(2011 paper literal, variant)", min_stars=3, max_ambiguous=1,
                 pivot_first=True)

__all__ = [
    "PlanarTriangleMatcher",
]
