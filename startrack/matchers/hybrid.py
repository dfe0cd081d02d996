"""Hybrid matcher (seed 000's method): angle lookups shortlist, planar triangles decide.

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

Unlike the triangle matcher it needs no triangle table (triangles are formed on the fly
from catalog vectors), so it covers every catalog star, not only the pattern stars.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np

from startrack.database import StarDatabase
from startrack.database.pairs import PairTable
from startrack.matchers.base import Matcher, MatcherConfig, register, register_variant
from startrack.matching import hybrid_kernels
from startrack.matching.features import feature_sigma, observed_features
from startrack.matching.geometry import angle_table, handedness
from startrack.matching.pairs import pair_index
from startrack.matching.triples import brightness_triples
from startrack.types import Hypothesis, MatchDiagnostics, Observation


def angle_votes(vectors: np.ndarray, database: StarDatabase, tolerance: float,
                diag: MatchDiagnostics, table: PairTable | None = None,
                ) -> tuple[np.ndarray, dict[tuple[int, int], np.ndarray]]:
    """Votes (n x catalog rows): in how many of observed star a's pair lookups each catalog
    star appears; and per observed pair (a < b) the matching catalog pairs as (K x 2) rows,
    both ways round. The lookups are in ``table`` (default: every catalog pair)."""
    n, n_cat = len(vectors), len(database.vectors)
    table = database.pairs if table is None else table
    votes = np.zeros((n, n_cat), np.int16)
    found: dict[tuple[int, int], np.ndarray] = {}
    mark = np.zeros(n_cat, bool)
    cos = np.clip(vectors @ vectors.T, -1.0, 1.0)
    for a, b in itertools.combinations(range(n), 2):
        theta = float(np.arccos(cos[a, b]))
        i, j, _ = table.query(theta - tolerance, theta + tolerance)
        diag.candidates += len(i)
        found[a, b] = np.column_stack([np.concatenate([i, j]), np.concatenate([j, i])])
        mark[:] = False
        mark[i] = mark[j] = True  # a star in several pairs of one lookup votes once
        votes[a] += mark
        votes[b] += mark
    return votes, found


@register
class HybridMatcher(Matcher):
    """Sedaghat, Toloei and Ghanbarpoor (2011): angle shortlists, then planar triangles."""

    name = "hybrid"
    description = "angle lookups shortlist catalog stars, planar triangles identify"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_false: int = 3, max_per_triangle: int = 5,
                 max_unconfirmed: int = 10, fourth_star: bool = True,
                 pattern_per_region: int | None = 15,
                 region_radius_deg: float | None = None) -> None:
        super().__init__(database, config)
        # The on-board catalog of the angle lookups: the pattern stars (fewer than
        # ``pattern_per_region`` brighter stars within ``region_radius_deg``, as Pyramid's
        # and the triangle table's), None for every catalog star.
        self.pattern_per_region = None if pattern_per_region is None else int(pattern_per_region)
        self.region_radius_deg = region_radius_deg
        self.fourth_star = bool(fourth_star)
        self.max_unconfirmed = max_unconfirmed  # per pass, best first
        self.max_false = max_false  # votes the last pass may miss (false partners)
        self.max_per_triangle = max_per_triangle

    def _table(self) -> PairTable:
        return self.database.pattern_pairs(self.pattern_per_region, self.region_radius_deg)

    def prepare(self) -> None:
        super().prepare()
        pair_index(self._table(), len(self.database.vectors))

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        tol = self.angle_tolerance(obs)
        table = self._table()
        votes, _ = angle_votes(obs.vectors[:n], self.database, tol, diag, table)
        index = pair_index(table, len(self.database.vectors))
        ang = angle_table(obs.vectors[:n])
        windows = {(a, b): np.array(index.window(ang[a, b] - tol, ang[a, b] + tol))
                   for a, b in itertools.combinations(range(n), 2)}
        triples = brightness_triples(n)
        sigma = feature_sigma(obs, self.config.tolerance_sigma, self.config.min_tolerance_rad)
        feats = observed_features(obs.vectors[:n], triples, sigma)
        diag.extra.update(triangles_tested=0, passes=0)
        for missed in range(min(self.max_false, n - 3) + 1):
            diag.extra["passes"] += 1
            yield from self._triangles(obs, votes >= n - 1 - missed, windows, triples,
                                       feats, diag)

    def _triangles(self, obs: Observation, shortlist: np.ndarray,
                   windows: dict, triples: list, feats: dict,
                   diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """The triangle test over the shortlisted catalog stars of every observed triple."""
        n = len(shortlist)
        vec = obs.vectors[:n]
        diag.extra["shortlist"] = shortlist.sum(axis=1).tolist()
        unconfirmed: list[tuple[float, Hypothesis]] = []

        k = self.config.tolerance_sigma
        cat = self.database.vectors
        index = pair_index(self._table(), len(cat))
        pi, pj, tol = index.pi, index.pj, self.angle_tolerance(obs)
        ang = angle_table(vec)
        heads = np.full(len(cat), -1, np.int64)
        for a, b, c in triples:
            if not (shortlist[a].any() and shortlist[b].any() and shortlist[c].any()):
                continue  # no catalog candidate for one of the stars
            features = np.array(feats[a, b, c])
            # The mirror image has the same area and moment: its handedness tells it apart.
            hand = (int(handedness(vec[a], vec[b], vec[c])) if features[0] > k * features[2]
                    else 0)
            trip, err, tested = hybrid_kernels.shortlisted_triangles(
                pi, pj, windows[a, b], windows[b, c], shortlist[a], shortlist[b],
                shortlist[c], cat, features, k, hand, heads)
            diag.extra["triangles_tested"] += int(tested)
            keep = np.argsort(err, kind="stable")[: self.max_per_triangle]
            if len(keep) == 0:
                continue
            if not self.fourth_star:
                for t in keep:
                    yield Hypothesis(np.array([a, b, c]), trip[t])
                continue
            # A chance triangle among hundreds of shortlisted stars is common on a dense
            # sky; one more star's three angles removes it before the costlier verification.
            confirmed = False
            for d in (d for d in range(n) if d not in (a, b, c)):
                diag.pivots += 1
                hit, w = hybrid_kernels.confirm(trip[keep], np.array([a, b, c]), d, ang,
                                                tol, shortlist[d], index.lists)
                for t, star in zip(keep[hit], w, strict=True):
                    yield Hypothesis(np.array([a, b, c, d]), np.append(trip[t], star))
                if len(hit):
                    confirmed = True
                    break
            if not confirmed:  # every other star false? verification may still accept
                unconfirmed += [(float(err[t]), Hypothesis(np.array([a, b, c]), trip[t]))
                                for t in keep]
        unconfirmed.sort(key=lambda item: item[0])
        for _, hyp in unconfirmed[: self.max_unconfirmed]:
            yield hyp


register_variant(HybridMatcher, "hybrid_nofourth",
                 "hybrid without the fourth-star check (seed 000 literal, variant)",
                 fourth_star=False)
