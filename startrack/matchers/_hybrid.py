"""Hybrid matcher (the 2011 paper's method): angle lookups shortlist, planar triangles decide.

First every pair of the brightest observed stars is looked up in the catalog pair table.
The angle method is not run to the end: it only *shortlists*, for each observed star a,
the catalog stars that appear in the lookups of a's pairs: all n - 1 of them in the first
pass. A false star spoils the lookups of every pair it is in, so while no hypothesis is
accepted, later passes ask for one vote fewer, down to n - 1 - ``max_false``.

Then the triangle test (area and polar moment, with the propagated sigmas) runs only over
triplets of shortlisted catalog stars: the catalog stars of two observed sides are joined
on their shared star, and the planar triangle they close is compared with the observed
one. The paper says the hybrid needs no pivoting; here a passing triangle goes to
verification with one more observed star whose three angles to it close on a shortlisted
catalog star (a cheap check: on a dense sky the shortlists hold hundreds of stars and
chance triangles are common). That fourth-star check is what the Pyramid matcher counts
as a pivot, and it is counted so here. Triangles no other star confirms (the rest may be
false stars) are tried last in each pass. ``fourth_star=False`` (the variant
``hybrid_nofourth``) leaves the check out, as the paper does: each passing triangle goes
to verification as it is.

``hybrid_single`` is the paper's hybrid and nothing more. Where the paper is silent it
takes the simplest reading: its one line on the shortlist ("first, with the angle
method, we make some catalog stars candidates for the stars in the field of view") says
nothing of how many angles must agree, so a catalog star is a candidate of an observed
star when any one of that star's angle lookups holds it (``min_votes=1``, one pass); the
triangle test is the paper's area and polar moment alone (``mirror_check=False``); and,
as it "does not pivot", a triangle answers only when exactly one catalog triangle passes
(``unique=True``: the paper's triangle method pivots when there are several), each
triangle of the five brightest stars on its own, no fourth star, no second round.

The angle lookups are in the pattern stars' pair table (as the angle matcher's: see
there): at 1 px noise on Hipparcos the first pass's shortlists then hold tens of stars,
not thousands. When every pass
over the ``config.max_stars`` brightest fails (false stars crowd them), a second round
runs the same passes on up to ``extra_stars`` more stars, whose votes may miss that many
more. The triangle search and the fourth-star check run compiled
(:class:`startrack._core.matchers.hybrid.HybridSearch`), returning at each confirmed triangle so
that
verification's first acceptance ends the search.

Unlike the triangle matcher it needs no triangle table (triangles are formed on the fly
from catalog vectors); with ``pattern_per_region=None`` it covers every catalog star.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator

import numpy as np

from startrack._core.matchers import hybrid as kernels
from startrack.database import PairTable, StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import MatcherConfig, register, register_variant
from startrack.matchers._shared.features import feature_sigma
from startrack.matchers._shared.geometry import angle_table, handedness
from startrack.matchers._shared.pair_joins import pair_index
from startrack.matchers._shared.pattern import PatternPairMatcher
from startrack.matchers._shared.triples import brightness_triples


def angle_votes(vectors: np.ndarray, database: StarDatabase, tolerance: float,
                diag: MatchDiagnostics, table: PairTable | None = None,
                ) -> tuple[np.ndarray, np.ndarray]:
    """Votes (n x catalog rows): in how many of observed star a's pair lookups each catalog
    star appears (once per lookup); and each observed pair's lookup as table entries
    [start, stop) (n x n x 2, symmetric). The lookups are in ``table`` (default: every
    catalog pair), compiled."""
    n = len(vectors)
    index = pair_index(database.pairs if table is None else table, len(database.vectors))
    ang = angle_table(vectors)
    windows = np.zeros((n, n, 2), np.int64)
    lo = np.searchsorted(index.angle, ang - tolerance, side="left")
    hi = np.searchsorted(index.angle, ang + tolerance, side="right")
    windows[..., 0], windows[..., 1] = lo, np.maximum(hi, lo)
    upper = np.triu_indices(n, 1)
    diag.candidates += int((windows[..., 1] - windows[..., 0])[upper].sum())
    votes = kernels.angle_votes(index.pi, index.pj, windows, index.n_catalog)
    return votes, windows


@functools.lru_cache(maxsize=16)
def _triples(n: int) -> np.ndarray:
    return np.array(brightness_triples(n), np.int64).reshape(-1, 3)


@register
class HybridMatcher(PatternPairMatcher):
    """Sedaghat, Toloei and Ghanbarpoor (2011): angle shortlists, then planar triangles."""

    name = "hybrid"
    description = "angle lookups shortlist catalog stars, planar triangles identify"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_false: int = 3, max_per_triangle: int = 5,
                 max_unconfirmed: int = 10, fourth_star: bool = True,
                 min_votes: int | None = None, unique: bool = False,
                 mirror_check: bool = True, **pattern) -> None:
        super().__init__(database, config, **pattern)  # pattern stars and extra_stars
        self.fourth_star = bool(fourth_star)
        # None: ours, passes from n - 1 votes down; k: one pass asking for k votes
        self.min_votes = None if min_votes is None else int(min_votes)
        self.unique = bool(unique)  # a triangle answers only with one catalog triangle
        self.mirror_check = bool(mirror_check)  # handedness beside area and moment
        self.max_unconfirmed = max_unconfirmed  # per pass, best first
        self.max_false = max_false  # votes the last pass may miss (false partners)
        self.max_per_triangle = max_per_triangle

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        first = min(self.config.max_stars, len(obs))
        if first < 3:
            return
        diag.extra.update(triangles_tested=0, passes=0)
        yield from self._round(obs, first, self.max_false, diag)
        # False stars crowd the brightest: the fainter ones join, and more votes may miss.
        n = self.star_count(obs)
        if n > first and self.min_votes is None:
            yield from self._round(obs, n, self.max_false + n - first, diag)

    def _round(self, obs: Observation, n: int, max_false: int,
               diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """Votes among the ``n`` brightest stars, then the passes that ask for n - 1 votes,
        one fewer each, down to n - 1 - ``max_false``."""
        vec = np.ascontiguousarray(obs.vectors[:n])
        tol, k = self.angle_tolerance(obs), self.config.tolerance_sigma
        votes, windows = angle_votes(vec, self.database, tol, diag, self._table())
        tri = _triples(n)
        # observed_features' numbers, compiled for one frame's few triples
        feats = kernels.triple_features(
            vec, tri, feature_sigma(obs, k, self.config.min_tolerance_rad))
        # The mirror image has the same area and moment: its handedness tells it apart,
        # unless the triangle is too flat for its sign to be sure.
        hands = np.where(feats[:, 0] > k * feats[:, 2],
                         handedness(vec[tri[:, 0]], vec[tri[:, 1]], vec[tri[:, 2]]),
                         0).astype(np.int64)
        if not self.mirror_check:
            hands[:] = 0  # 0: no handedness asked of the catalog triangle
        frame = kernels.HybridFrame(tri, feats, hands, angle_table(vec), tol, k)
        if self.min_votes is not None:
            diag.extra["passes"] += 1
            yield from self._triangles(frame, tri, windows, votes >= self.min_votes, diag)
            return
        for missed in range(min(max_false, n - 3) + 1):
            diag.extra["passes"] += 1
            yield from self._triangles(frame, tri, windows, votes >= n - 1 - missed, diag)

    def _triangles(self, frame: kernels.HybridFrame, tri: np.ndarray, windows: np.ndarray,
                   shortlist: np.ndarray, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """The triangle test over the shortlisted catalog stars of every observed triple."""
        diag.extra["shortlist"] = shortlist.sum(axis=1).tolist()
        index = pair_index(self._table(), len(self.database.vectors))
        search = kernels.HybridSearch(
            frame, kernels.ShortPairs(index.pi, index.pj, windows, shortlist), shortlist,
            self.database.vectors, index.neighbours, self._heads,
            self.max_per_triangle, self.max_unconfirmed)
        if self.fourth_star:
            yield from self._confirmed(search, tri, diag)
            return
        t = 0
        while t < len(tri):
            # The compiled search passes over the triples without a catalog triangle.
            t, trip, err = search.next_triangles(t)
            diag.extra["triangles_tested"] = search.tested
            if t < len(tri) and not (self.unique and len(trip) > 1):
                for r in np.argsort(err, kind="stable")[: self.max_per_triangle]:
                    yield Hypothesis(tri[t].copy(), trip[r])
            t += 1

    def _confirmed(self, search: kernels.HybridSearch, tri: np.ndarray,
                   diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """The triangles that a fourth star confirms, in triple order; then, best first, at
        most ``max_unconfirmed`` of those none confirms (every other star false?
        verification may still accept one)."""
        # A chance triangle among hundreds of shortlisted stars is common on a dense sky;
        # one more star's three angles removes it before the costlier verification.
        counted, t = [0, 0], 0
        while t < len(tri):
            t, d, rows = search.next_confirmed(t)
            diag.extra["triangles_tested"] += search.tested - counted[0]
            diag.pivots += search.fourth_tried - counted[1]
            counted = [search.tested, search.fourth_tried]
            if t < len(tri):
                cols = np.append(tri[t], d)
                for row in rows:
                    yield Hypothesis(cols, row)
            t += 1
        for r in range(search.best_kept):
            yield Hypothesis(search.best_rows[r, :3].copy(), search.best_rows[r, 3:].copy())

    @functools.cached_property
    def _heads(self) -> np.ndarray:
        # The kernels' grouping heads: all -1 between calls, one per matcher for every frame.
        return np.full(len(self.database.vectors), -1, np.int64)


register_variant(HybridMatcher, "hybrid_nofourth",
                 "hybrid without the fourth-star check (variant)", fourth_star=False)
# The paper's hybrid as written (the module's last paragraph): a catalog star any angle
# lookup of a star holds is its candidate; a triangle answers when one catalog triangle
# passes area and polar moment; no pivot, no fourth star, no second pass.
register_variant(HybridMatcher, "hybrid_single",
                 "hybrid as the 2011 paper writes it: any angle's lookup shortlists, a "
                 "triangle answers with one catalog triangle only, no pivot (variant)",
                 fourth_star=False, min_votes=1, unique=True, mirror_check=False,
                 max_per_triangle=1, extra_stars=0)

__all__ = [
    "HybridMatcher", "angle_votes",
]
