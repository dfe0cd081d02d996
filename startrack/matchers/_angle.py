"""Angle method with pivoting (the 2011 paper): star pairs looked up by angle, narrowed by pivots.

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
pivot shares one star with the last pair, no closing angle). The variant ``angle_closed``
is "all"; ``angle_open`` is the paper's chain whole: one chain (``max_chains=1``, from
the three brightest stars on through the others by brightness), "none", no star skipped
(``max_skips=0``), and a chain that ends with several answers, or runs out of stars
before one is left, is indeterminate (``max_ambiguous=1``).

Two stars are enough, as the paper says of the angle method ("in the angle method two
stars are needed"): their one angle is an answer when its window holds at most
``max_ambiguous`` catalog pairs (one, in the paper's words "if an angle can be matched to
one pair of stars"), each pair handed on both ways round, since one angle cannot tell
which star is which.

The on-board catalog the pairs are looked up in is the pattern stars' pair table (stars
with fewer than ``pattern_per_region`` brighter ones within half the FOV, as Pyramid's
and the triangle table's): a frame's brightest stars are pattern stars, and at 1 px noise
on Hipparcos Hp <= 6.5 a window then holds hundreds of pairs instead of ~13 000, so the
joins stay small; verification still uses the whole catalog. ``pattern_per_region=None``
looks pairs up among every catalog star. When the chains of the ``config.max_stars``
brightest stars leave no answer (false stars crowd them), those that start from triples
with up to ``extra_stars`` fainter stars follow (Pyramid's order of triples).

The chains run compiled (:mod:`startrack._core.matchers.angle`, over the shared joins of
:mod:`startrack._core.database.pair_tables`), returning at each chain that leaves an answer so that
verification's first acceptance ends the search. Given verification's first-test radius
(``screen_rad``), an answer is only the hypotheses that pass that test: on a frame of no
stars nearly every chain leaves one that it refuses, and testing them in the search
instead of one Python round trip each is what makes the "no" fast.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator

import numpy as np

from startrack._core.matchers import angle as core
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import MatcherConfig, register, register_variant
from startrack.matchers._shared.geometry import angle_table
from startrack.matchers._shared.pair_joins import PairIndex, compact_pairs, pair_index
from startrack.matchers._shared.pattern import PatternPairMatcher
from startrack.matchers._shared.triples import triple_array

CLOSING = ("until_one", "all", "none")


@register
class AngleMatcher(PatternPairMatcher):
    """The 2011 paper's angle method: pair lookups with pivoting on shared stars."""

    name = "angle"
    description = "inter-star angles, pivoting on pairs that share a star (2011 paper)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_chains: int = 220, max_lookups: int = 1600, max_skips: int = 5,
                 max_ambiguous: int = 4, max_rows: int = 2_000_000,
                 closing: str = "until_one", **pattern) -> None:
        super().__init__(database, config, **pattern)  # pattern stars and extra_stars
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

    def prepare(self) -> None:
        super().prepare()  # the pattern pairs' index
        _ = self._slot_vectors  # and the slots themselves

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        n = self.star_count(obs)
        if n == 2:
            yield from self._one_angle(obs, diag)
        if n < 3:
            return
        first = min(self.config.max_stars, n)
        index = pair_index(self._table(), len(self.database.vectors))
        pi, pj, slot_rows = self._slots
        # Each chain starts from another ordering of the stars: the first three of a triple
        # in spreading order, then the rest by brightness, down to the triple's faintest
        # star when it is one of the extra stars.
        triples = triple_array(first, n, self.max_chains)
        windows = self._windows(index, obs.vectors[:n], self.angle_tolerance(obs))
        # Verification's first test inside the search: the answers it would refuse (nearly
        # all of a frame of no stars) never come back to Python one by one.
        frame = core.AngleFrame(self._limits, windows, pi, pj, obs.vectors[:n],
                                self._slot_vectors,
                                -2.0 if screen_rad is None else math.cos(screen_rad))
        base = (diag.pivots, diag.candidates, dict(diag.extra))
        t = 0
        while t < len(triples):
            t, cols, rows = core.next_chain(frame, triples, t, first)
            _count(frame, base, diag)
            for row in slot_rows[rows] if t < len(triples) else ():
                yield Hypothesis(cols.copy(), row)
            t += 1

    def _one_angle(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        """Two stars: the catalog pairs in their angle's window, each both ways round,
        when there are at least one and at most ``max_ambiguous``."""
        index = pair_index(self._table(), len(self.database.vectors))
        windows = self._windows(index, obs.vectors[:2], self.angle_tolerance(obs))
        start, stop = (int(v) for v in windows[0, 1])
        diag.candidates += max(stop - start, 0)
        diag.extra["lookups"] = diag.extra.get("lookups", 0) + 1
        if not 1 <= stop - start <= max(self.max_ambiguous, 1):
            return
        for e in range(start, stop):
            i, j = int(index.pi[e]), int(index.pj[e])
            for rows in ((i, j), (j, i)):
                yield Hypothesis(np.array([0, 1], np.int64), np.array(rows, np.int64))

    @property
    def _limits(self) -> core.AngleLimits:
        return core.AngleLimits(self.max_skips, self.max_ambiguous, self.max_rows,
                                CLOSING.index(self.closing), self.max_lookups)

    @staticmethod
    def _windows(index: PairIndex, vectors: np.ndarray, tol: float) -> np.ndarray:
        """Each observed pair's table entries [start, stop) (n x n x 2): the catalog pairs
        whose angle lies within ``tol`` of the observed one."""
        ang = angle_table(vectors)
        windows = np.empty(ang.shape + (2,), np.int64)
        windows[..., 0] = np.searchsorted(index.angle, ang - tol, side="left")
        windows[..., 1] = np.searchsorted(index.angle, ang + tol, side="right")
        return windows

    @functools.cached_property
    def _slot_vectors(self) -> np.ndarray:
        return np.ascontiguousarray(self.database.vectors[self._slots[2]], dtype=np.float64)

    @functools.cached_property
    def _slots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # The search's numbering of the table's stars (its "slots").
        index = pair_index(self._table(), len(self.database.vectors))
        return compact_pairs(index.pi, index.pj)


def _count(frame: core.AngleFrame, base: tuple, diag: MatchDiagnostics) -> None:
    """The search's counters (:class:`startrack._core.matchers.angle.AngleFrame`) into ``diag``, on
    top of what it held before the search (``base``), keys in the order they arose."""
    pivots, candidates, extra = base
    diag.pivots = pivots + frame.pivots
    diag.candidates = candidates + frame.candidates
    events = [("chains", frame.chains), ("lookups", frame.lookups),
              ("skipped", frame.skipped), ("ambiguous", frame.ambiguous)]
    if frame.ambiguous_first:  # ambiguous answers may come first
        events[2], events[3] = events[3], events[2]
    for key, value in events:
        if value:
            diag.extra[key] = extra.get(key, 0) + value if key != "chains" else value


register_variant(AngleMatcher, "angle_closed",
                 "angle method, every closing angle checked (variant)", closing="all")
# The paper's chain: one chain, each pivot shares one star with the last pair, no star is
# left out, and a chain that does not end with one answer is "indeterminate" (none).
register_variant(AngleMatcher, "angle_open",
                 "angle method, the 2011 paper's chain: one chain, no closing angle, no "
                 "skipped star, one answer or none (variant)", closing="none", max_skips=0,
                 max_ambiguous=1, max_chains=1)

__all__ = [
    "AngleMatcher",
]
