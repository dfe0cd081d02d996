"""Pyramid (Mortari, Samaan, Bruccoleri, Junkins 2004): a triangle of pair lookups, confirmed
by a fourth star.

For star triples (i, j, k) in the paper's spreading order, the three sides are looked up
in the pair k-vector and joined into the catalog triangles consistent with all three; the
mirror image is rejected by the sign of the triple product (a rotation keeps it, a
reflection flips it). Each surviving triangle is then tested against the fourth stars r in
turn: the angles from r to i, j and k must all match the angles from one catalog star R to
the triangle's stars, and R must lie where the triangle's attitude puts r. The brightest
r with 1 to ``max_pyramids`` pyramids gives the hypotheses (several: double stars closer
than the noise); with three stars only, a triangle that unique is.

Pattern stars (as tetra3 does): the triangles are looked up first among the catalog's
brighter stars only (``pattern_per_region``: stars with fewer brighter ones within half
the FOV), whose pair table is ~18x smaller on Hipparcos Hp <= 6.5 at 20 deg, so each lookup
at 1 px noise returns hundreds of pairs instead of tens of thousands. A frame's brightest
stars are pattern stars; the fourth star and the verification use the whole catalog, and
with ``fallback`` (off by default) the full pair table is searched, for a bounded number
of triples, when no pattern-star hypothesis passed.
Because the triples are then cheap, up to ``extra_stars`` fainter stars join when bright
false stars spoil the brightest ``config.max_stars``.

The triple loop, the joins and the confirmation run compiled, up to the first triple
that gives hypotheses in one call (:mod:`startrack._core.matchers.pyramid`); the matcher hands
over one triple's hypotheses at a time, so that verification's first acceptance ends the
search.
"""

from __future__ import annotations

from collections.abc import Iterator

from startrack._core.matchers import pyramid as core
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import MatcherConfig, register
from startrack.matchers._shared.pair_joins import pair_index
from startrack.matchers._shared.pattern import PatternPairMatcher
from startrack.matchers._shared.triples import triple_array

# The fourth star's catalog candidates must lie within this many angle tolerances of
# where a triangle's attitude puts it: its three angles then pin it much closer, and a
# nearly flat triangle's mirror point is refused.
CONFIRM_RADIUS = 3.0


@register
class PyramidMatcher(PatternPairMatcher):
    """Mortari's Pyramid on the shared pair database."""

    name = "pyramid"
    description = "triangle of pair lookups confirmed by a fourth star (Mortari et al. 2004)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_triples: int = 220, max_triangles: int = 500, max_pyramids: int = 4,
                 fallback: bool = False, fallback_triples: int = 56, **pattern) -> None:
        super().__init__(database, config, **pattern)  # pattern stars and extra_stars
        self.max_triples = int(max_triples)  # triples tried per frame on the pattern pairs
        self.max_triangles = int(max_triangles)  # more catalog triangles: triple skipped
        # More confirmed pyramids than this: ambiguous, try another fourth star. A few are
        # handed to verification, for double stars closer than the noise match either way.
        self.max_pyramids = int(max_pyramids)
        # Patterns are first looked up among the pattern stars only (fewer than
        # ``pattern_per_region`` brighter stars within ``region_radius_deg``): a frame's
        # brightest stars are pattern stars, and each lookup returns far fewer pairs. With
        # ``fallback`` the full pair table follows when no pattern-star hypothesis passed,
        # for at most ``fallback_triples`` triples: off by default, since on a dense sky
        # each full-table triple costs ~100 pattern-star ones, and a frame with no star
        # pattern at all (junk) would pay it on every try.
        self.fallback = bool(fallback)
        self.fallback_triples = int(fallback_triples)
        self._searches: tuple | None = None  # made by the first search

    def _tables(self) -> list:
        tables = [self._table()]
        if self.pattern_per_region is not None and self.fallback:
            tables.append(self.database.pairs)
        return tables

    def _search_tables(self) -> tuple[core.PyramidSearch, list[tuple[bool, object, int]]]:
        # Looked up once: per frame the lookups cost as much as a search's first triples.
        n_cat = len(self.database.vectors)
        search = core.PyramidSearch(self.database.vectors,
                                    pair_index(self.database.pairs, n_cat).neighbours,
                                    self.max_triangles, self.max_pyramids)
        self._searches = search, [(bool(k), pair_index(table, n_cat).neighbours,
                                   self.fallback_triples if k else self.max_triples)
                                  for k, table in enumerate(self._tables())]
        return self._searches

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        n = self.star_count(obs)
        if n < 3:
            return
        tol = self.angle_tolerance(obs)
        first = min(self.config.max_stars, n)
        search, tables = self._searches or self._search_tables()
        frame = core.PyramidFrame(obs.vectors[:n], tol, CONFIRM_RADIUS * tol)
        for fallback, tab, limit in tables:
            diag.extra["fallback"] = fallback
            triples = triple_array(first, n, limit)
            start = 0
            while start < len(triples):
                start, cols, rows = core.search(search, frame, tab, triples, start)
                self._count(frame, diag)
                for row in rows:
                    yield Hypothesis(cols, row)

    @staticmethod
    def _count(frame: core.PyramidFrame, diag: MatchDiagnostics) -> None:
        diag.extra["triples"], diag.extra["triangles"] = frame.triples, frame.triangles
        diag.candidates, diag.pivots = frame.candidates, frame.pivots

__all__ = [
    "PyramidMatcher",
]
