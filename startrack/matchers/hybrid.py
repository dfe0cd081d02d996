"""Hybrid matcher (seed 000's method): angle lookups shortlist, planar triangles decide.

First every pair of the brightest observed stars is looked up in the catalog pair table.
The angle method is not run to the end: it only *shortlists*, for each observed star a,
the catalog stars that appear in the lookups of a's pairs: all n - 1 of them in the first
pass. A false star spoils the lookups of every pair it is in, so while no hypothesis is
accepted, later passes ask for one vote fewer, down to n - 1 - ``max_false``.

Then the triangle test (area and polar moment, with the propagated sigmas) runs only over
triplets of shortlisted catalog stars: the catalog stars of two observed sides are joined
on their shared star, and the planar triangle they close is compared with the observed
one. No pivoting: a passing triangle goes to verification with one more observed star
whose three angles to it close on a shortlisted catalog star (a cheap check: on a dense
sky the shortlists hold hundreds of stars and chance triangles are common). Triangles no
other star confirms (the rest may be false stars) are tried last in each pass.

Unlike the triangle matcher it needs no triangle table (triangles are formed on the fly
from catalog vectors), so it covers every catalog star, not only the pattern stars.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np

from startrack.database import StarDatabase
from startrack.database.triangles import triangle_features
from startrack.matchers.base import Matcher, MatcherConfig, register
from startrack.matching.features import feature_sigma, observed_features
from startrack.matching.geometry import handedness
from startrack.matching.pairs import join_sorted, member_pairs
from startrack.matching.triples import brightness_triples
from startrack.types import Hypothesis, MatchDiagnostics, Observation


def angle_votes(vectors: np.ndarray, database: StarDatabase, tolerance: float,
                diag: MatchDiagnostics) -> tuple[np.ndarray, dict[tuple[int, int], np.ndarray]]:
    """Votes (n x catalog rows): in how many of observed star a's pair lookups each catalog
    star appears; and per observed pair (a < b) the matching catalog pairs as (K x 2) rows,
    both ways round."""
    n, n_cat = len(vectors), len(database.vectors)
    votes = np.zeros((n, n_cat), np.int16)
    found: dict[tuple[int, int], np.ndarray] = {}
    mark = np.zeros(n_cat, bool)
    cos = np.clip(vectors @ vectors.T, -1.0, 1.0)
    for a, b in itertools.combinations(range(n), 2):
        theta = float(np.arccos(cos[a, b]))
        i, j, _ = database.pairs.query(theta - tolerance, theta + tolerance)
        diag.candidates += len(i)
        found[a, b] = np.column_stack([np.concatenate([i, j]), np.concatenate([j, i])])
        mark[:] = False
        mark[i] = mark[j] = True  # a star in several pairs of one lookup votes once
        votes[a] += mark
        votes[b] += mark
    return votes, found


def oriented(found: dict[tuple[int, int], np.ndarray], a: int, b: int) -> np.ndarray:
    """Catalog pairs (x, y) for the observed pair, x standing for a and y for b."""
    return found[a, b] if a < b else found[b, a][:, ::-1]


def confirm(trip: np.ndarray, sides: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Candidates (K x 3 catalog rows for observed a, b, c) that a fourth observed star d
    confirms: some catalog star w with (x, w), (y, w), (z, w) in ``sides`` (the catalog
    pairs of (a, d), (b, d), (c, d)). Returns (candidate index, w), one row per match."""
    ad, bd, cd = sides
    if len(trip) == 0 or min(len(ad), len(bd), len(cd)) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    first = join_sorted(np.column_stack([np.arange(len(trip)), trip[:, 0]]), (1,), ad, False)
    k, w = first[:, 0], first[:, 2]
    ok = member_pairs(trip[k, 1], w, bd) & member_pairs(trip[k, 2], w, cd)
    return k[ok], w[ok]


@register
class HybridMatcher(Matcher):
    """Sedaghat, Toloei and Ghanbarpoor (2011): angle shortlists, then planar triangles."""

    name = "hybrid"
    description = "angle lookups shortlist catalog stars, planar triangles identify"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_false: int = 3, max_per_triangle: int = 5,
                 max_unconfirmed: int = 10) -> None:
        super().__init__(database, config)
        self.max_unconfirmed = max_unconfirmed  # per pass, best first
        self.max_false = max_false  # votes the last pass may miss (false partners)
        self.max_per_triangle = max_per_triangle

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        votes, found = angle_votes(obs.vectors[:n], self.database, self.angle_tolerance(obs),
                                   diag)
        triples = brightness_triples(n)
        sigma = feature_sigma(obs, self.config.tolerance_sigma, self.config.min_tolerance_rad)
        feats = observed_features(obs.vectors[:n], triples, sigma)
        diag.extra.update(triangles_tested=0, passes=0)
        for missed in range(min(self.max_false, n - 3) + 1):
            diag.extra["passes"] += 1
            yield from self._triangles(obs, votes >= n - 1 - missed, found, triples, feats,
                                       diag)

    def _triangles(self, obs: Observation, shortlist: np.ndarray,
                   found: dict[tuple[int, int], np.ndarray], triples: list,
                   feats: dict, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """The triangle test over the shortlisted catalog stars of every observed triple."""
        n = len(shortlist)
        vec = obs.vectors[:n]
        diag.extra["shortlist"] = shortlist.sum(axis=1).tolist()
        edges: dict[tuple[int, int], np.ndarray] = {}
        unconfirmed: list[tuple[float, Hypothesis]] = []

        def side(a: int, b: int) -> np.ndarray:
            if (a, b) not in edges:
                e = oriented(found, a, b)
                edges[a, b] = e[shortlist[a][e[:, 0]] & shortlist[b][e[:, 1]]]
            return edges[a, b]

        k = self.config.tolerance_sigma
        cat = self.database.vectors
        for a, b, c in triples:
            if not (shortlist[a].any() and shortlist[b].any() and shortlist[c].any()):
                continue  # no catalog candidate for one of the stars
            trip = join_sorted(side(a, b), (1,), side(b, c))
            diag.extra["triangles_tested"] += len(trip)
            if len(trip) == 0:
                continue
            obs_tri = vec[[a, b, c]]
            area, polar, s_area, s_polar = feats[a, b, c]
            ca, cp = triangle_features(cat[trip[:, 0]], cat[trip[:, 1]], cat[trip[:, 2]])
            err = np.hypot((ca - area) / s_area, (cp - polar) / s_polar)
            ok = (np.abs(ca - area) <= k * s_area) & (np.abs(cp - polar) <= k * s_polar)
            if area > k * s_area:  # the mirror image has the same area and moment
                hand = handedness(cat[trip[:, 0]], cat[trip[:, 1]], cat[trip[:, 2]])
                ok &= hand == handedness(obs_tri[0], obs_tri[1], obs_tri[2])
            keep = np.flatnonzero(ok)
            keep = keep[np.argsort(err[keep], kind="stable")][: self.max_per_triangle]
            if len(keep) == 0:
                continue
            # A chance triangle among hundreds of shortlisted stars is common on a dense
            # sky; one more star's three angles removes it before the costlier verification.
            confirmed = False
            for d in (d for d in range(n) if d not in (a, b, c)):
                hit, w = confirm(trip[keep], [side(a, d), side(b, d), side(c, d)])
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
