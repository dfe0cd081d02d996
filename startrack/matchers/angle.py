"""Angle method with pivoting (seed 000): star pairs looked up by angle, narrowed by pivots.

A hypothesis assigns catalog rows to a growing chain of observed stars; the candidates
are kept as an (n_hypotheses x n_chain_stars) array of catalog rows. One observed pair
gives every catalog pair within the angle window, in both orientations. Each further
lookup ("pivot") is an observed pair that shares a star with the last one: a pair to a
new star joins the candidates on the shared star and appends one column; a pair between
two chain stars keeps only the rows whose two catalog stars form a candidate pair. The
pivots go on until one hypothesis remains or the stars run out.

``closing`` says how many of the closing pairs (new star to earlier chain stars) are
looked up: "until_one" (ours: until one hypothesis is left, so the last star's other
angles may go unchecked), "all" (every one), "none" (the paper's literal chain: each
pivot shares one star with the last pair, no closing angle). The variants ``angle_closed``
and ``angle_open`` are the last two.

The on-board catalog the pairs are looked up in is the pattern stars' pair table (stars
with fewer than ``pattern_per_region`` brighter ones within half the FOV, as Pyramid's
and the triangle table's): a frame's brightest stars are pattern stars, and at 1 px noise
on Hipparcos Hp <= 6.5 a window then holds hundreds of pairs instead of ~13 000, so the
joins stay small; verification still uses the whole catalog. ``pattern_per_region=None``
looks pairs up among every catalog star. When the chains of the ``config.max_stars``
brightest stars leave no answer (false stars crowd them), those that start from triples
with up to ``extra_stars`` fainter stars follow (Pyramid's order of triples).

The lookups and joins are the shared ones of :mod:`startrack.matching.pairs` (compiled).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from startrack.database import StarDatabase
from startrack.database.pairs import PairTable
from startrack.matchers.base import Matcher, MatcherConfig, register, register_variant
from startrack.matching.pairs import PairLookup, join_close, join_extend, pair_index
from startrack.matching.triples import triple_order
from startrack.types import Hypothesis, MatchDiagnostics, Observation

CLOSING = ("until_one", "all", "none")


@register
class AngleMatcher(Matcher):
    """Seed 000's angle method: pair lookups with pivoting on shared stars."""

    name = "angle"
    description = "inter-star angles, pivoting on pairs that share a star (seed 000)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_chains: int = 220, max_lookups: int = 1600, max_skips: int = 5,
                 max_ambiguous: int = 4, max_rows: int = 2_000_000,
                 closing: str = "until_one", pattern_per_region: int | None = 15,
                 region_radius_deg: float | None = None, extra_stars: int | None = None) -> None:
        super().__init__(database, config)
        if closing not in CLOSING:
            raise ValueError(f"closing must be one of {', '.join(CLOSING)}, got {closing!r}")
        self.closing = closing
        self.max_chains = int(max_chains)  # star orderings tried per frame
        self.max_lookups = int(max_lookups)  # pair steps (memoised or not) per frame
        self.max_skips = int(max_skips)  # stars one chain may leave out
        # A chain that runs out of stars with this many hypotheses or fewer hands them all
        # to verification (1 = the paper's strict reading: an ambiguous chain says nothing).
        # Double stars closer than the centroid noise stay ambiguous whatever the pivots.
        self.max_ambiguous = int(max_ambiguous)
        self.max_rows = int(max_rows)  # a chain whose candidates outgrow this is dropped
        # The on-board catalog the pairs are looked up in: the pattern stars (fewer than
        # ``pattern_per_region`` brighter stars within ``region_radius_deg``, as Pyramid's
        # and the triangle table's), None for every catalog star.
        self.pattern_per_region = None if pattern_per_region is None else int(pattern_per_region)
        self.region_radius_deg = region_radius_deg
        # When the ``config.max_stars`` brightest leave no answer (false stars crowd them),
        # the chains that start with up to this many fainter stars are tried next.
        self.extra_stars = int(self.config.extra_stars if extra_stars is None else extra_stars)

    def _table(self) -> PairTable:
        return self.database.pattern_pairs(self.pattern_per_region, self.region_radius_deg)

    def prepare(self) -> None:
        super().prepare()
        pair_index(self._table(), len(self.database.vectors))

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars + max(self.extra_stars, 0), len(obs))
        if n < 3:
            return
        first = min(self.config.max_stars, n)
        index = pair_index(self._table(), len(self.database.vectors))
        lookup = PairLookup(index, obs.vectors[:n], self.angle_tolerance(obs), diag)
        budget = [self.max_lookups]
        # Each chain starts from another ordering of the stars: the first three of a triple
        # in spreading order, then the rest by brightness, down to the triple's faintest
        # star when it is one of the extra stars.
        for chain, start in enumerate(triple_order(first, n, self.max_chains)):
            if budget[0] <= 0:
                break
            diag.extra["chains"] = chain + 1
            stars = range(max(first, start[2] + 1))
            order = list(start) + [s for s in stars if s not in start]
            found = self._chain(order, lookup, diag, budget)
            if found is not None:
                cols, rows = found
                for row in rows:
                    yield Hypothesis(np.asarray(cols, np.int64), row.astype(np.int64))

    def _chain(self, order: list[int], lookup: PairLookup, diag: MatchDiagnostics,
               budget: list[int]) -> tuple[list[int], np.ndarray] | None:
        """Pivot from the pair (order[0], order[1]) through the other stars in turn.

        Each new star q comes in by the pair (newest chain star, q); then the pairs
        (q, earlier chain star), each sharing q with the one before, close the chain until
        one hypothesis is left. A star that leaves no hypothesis is taken out again (the
        chain then continues as if it had been ordered without it): it is most likely a
        false star. Returns (observed stars, hypotheses as rows of catalog rows) when one
        hypothesis remains, or at most ``max_ambiguous`` when the stars run out.
        """
        hyps = lookup.pairs(order[0], order[1])
        budget[0] -= 1
        if len(hyps) == 0:
            return None
        cols, skips = list(order[:2]), 0
        for q in order[2:]:
            if len(cols) >= 3 and len(hyps) == 1:
                break
            if budget[0] <= 0 or skips > self.max_skips:
                return None
            before = hyps
            budget[0] -= 1
            diag.pivots += 1
            hyps, total = join_extend(hyps, len(cols) - 1, lookup, cols[-1], q,
                                      self.max_rows + 1)
            for col_t in range(len(cols) - 1 if self.closing != "none" else 0):
                if budget[0] <= 0 or total > self.max_rows or len(hyps) == 0 or (
                        len(hyps) == 1 and self.closing == "until_one"):
                    break
                budget[0] -= 1
                diag.pivots += 1
                hyps = join_close(hyps, len(cols), col_t, lookup, q, cols[col_t])
            if len(hyps) == 0 or total > self.max_rows:
                hyps, skips = before, skips + 1
                diag.extra["skipped"] = diag.extra.get("skipped", 0) + 1
                continue
            cols.append(q)
        if len(cols) >= 3 and 1 <= len(hyps) <= max(self.max_ambiguous, 1):
            if len(hyps) > 1:
                diag.extra["ambiguous"] = diag.extra.get("ambiguous", 0) + 1
            return cols, hyps
        return None


register_variant(AngleMatcher, "angle_closed",
                 "angle method, every closing angle checked (variant)", closing="all")
register_variant(AngleMatcher, "angle_open",
                 "angle method, no closing angle (seed 000 literal, variant)", closing="none")
