"""Angle method with pivoting (seed 000): star pairs looked up by angle, narrowed by pivots.

A hypothesis assigns catalog rows to a growing chain of observed stars; the candidates
are kept as an (n_hypotheses x n_chain_stars) array of catalog rows. One observed pair
gives every catalog pair within the angle window, in both orientations. Each further
lookup ("pivot") is an observed pair that shares a star with the last one: a pair to a
new star joins the candidates on the shared star and appends one column; a pair between
two chain stars keeps only the rows whose two catalog stars form a candidate pair. The
pivots go on until one hypothesis remains or the stars run out.

The join helpers here (:class:`PairLookup`, :func:`join_extend`, :func:`join_close`)
also serve the Pyramid matcher.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import cached_property

import numpy as np

from startrack.database import StarDatabase
from startrack.database.pairs import PairTable
from startrack.matchers.base import Matcher, MatcherConfig, register
from startrack.types import Hypothesis, MatchDiagnostics, Observation


class PairCandidates:
    """Catalog pairs that one observed pair (p, q) may be: p is cp[m] while q is cq[m].

    Grouped by cp with a start index per catalog row, so that a join reads each
    hypothesis's partners directly, and as sorted keys cp * n_catalog + cq for membership
    tests; each form is built the first time a join needs it.
    """

    def __init__(self, cp: np.ndarray, cq: np.ndarray, n_catalog: int) -> None:
        self.cp, self.cq = cp, cq
        self.n_catalog = n_catalog

    @cached_property
    def starts(self) -> np.ndarray:
        """Partners of catalog row c are ``partners[starts[c]:starts[c + 1]]``."""
        counts = np.bincount(self.cp, minlength=self.n_catalog)
        return np.concatenate([[0], np.cumsum(counts)])

    @cached_property
    def partners(self) -> np.ndarray:
        return self.cq[np.argsort(self.cp, kind="stable")]

    @cached_property
    def keys(self) -> np.ndarray:
        return np.sort(self.cp * self.n_catalog + self.cq)

    def __len__(self) -> int:
        return len(self.cp)


class PairLookup:
    """Catalog pair candidates for the observed pairs of one frame, memoised.

    ``lookup(p, q)`` gives the :class:`PairCandidates` of the observed pair p-q: both
    orientations of every catalog pair whose angle lies within ``tol`` of the observed
    angle. Only first lookups count as database candidates.
    """

    def __init__(self, pairs: PairTable, vectors: np.ndarray, tol: float, n_catalog: int,
                 diag: MatchDiagnostics) -> None:
        self.pairs = pairs
        self.angles = np.arccos(np.clip(vectors @ vectors.T, -1.0, 1.0))
        self.tol = tol
        self.n_catalog = n_catalog
        self.diag = diag
        self._raw: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._memo: dict[tuple[int, int], PairCandidates] = {}

    def __call__(self, p: int, q: int) -> PairCandidates:
        if (p, q) in self._memo:
            return self._memo[p, q]
        key = (min(p, q), max(p, q))
        if key not in self._raw:
            theta = self.angles[key]
            i, j, _ = self.pairs.query(theta - self.tol, theta + self.tol)
            self.diag.candidates += len(i)
            self.diag.extra["lookups"] = self.diag.extra.get("lookups", 0) + 1
            self._raw[key] = (np.concatenate([i, j]).astype(np.int64),
                              np.concatenate([j, i]).astype(np.int64))
        cp, cq = self._raw[key]
        if p != key[0]:
            cp, cq = cq, cp
        self._memo[p, q] = PairCandidates(cp, cq, self.n_catalog)
        return self._memo[p, q]


def join_extend(hyps: np.ndarray, col: int, cand: PairCandidates) -> np.ndarray:
    """Join on a shared star: every row whose column ``col`` is some cp[m] becomes one row
    per such m, with cq[m] appended; rows that would use a catalog star twice go."""
    if len(hyps) == 0 or len(cand) == 0:
        return np.zeros((0, hyps.shape[1] + 1), np.int64)
    key = hyps[:, col]
    left = cand.starts[key]
    counts = cand.starts[key + 1] - left
    rows = np.repeat(np.arange(len(hyps)), counts)
    first = np.cumsum(counts) - counts
    new = cand.partners[left[rows] + np.arange(len(rows)) - first[rows]]
    old = hyps[rows]
    keep = np.all(old != new[:, None], axis=1)
    return np.column_stack([old[keep], new[keep]])


def join_close(hyps: np.ndarray, col_p: int, col_q: int, cand: PairCandidates) -> np.ndarray:
    """Keep the rows whose catalog stars in columns (col_p, col_q) are a candidate pair."""
    if len(hyps) == 0 or len(cand) == 0:
        return hyps[:0]
    wanted = hyps[:, col_p] * cand.n_catalog + hyps[:, col_q]
    pos = np.minimum(np.searchsorted(cand.keys, wanted), len(cand.keys) - 1)
    return hyps[cand.keys[pos] == wanted]


def smart_triples(n: int) -> Iterator[tuple[int, int, int]]:
    """Star triples i < j < k in Mortari's Pyramid order (index gaps dj, dk outermost), which
    spreads the stars over the first tries so that a false star is soon left out."""
    for dj in range(1, n - 1):
        for dk in range(1, n - dj):
            for i in range(n - dj - dk):
                yield i, i + dj, i + dj + dk


@register
class AngleMatcher(Matcher):
    """Seed 000's angle method: pair lookups with pivoting on shared stars."""

    name = "angle"
    description = "inter-star angles, pivoting on pairs that share a star (seed 000)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 max_chains: int = 56, max_lookups: int = 400, max_skips: int = 2,
                 max_ambiguous: int = 4, max_rows: int = 2_000_000) -> None:
        super().__init__(database, config)
        self.max_chains = int(max_chains)  # star orderings tried per frame
        self.max_lookups = int(max_lookups)  # pair steps (memoised or not) per frame
        self.max_skips = int(max_skips)  # stars one chain may leave out
        # A chain that runs out of stars with this many hypotheses or fewer hands them all
        # to verification (1 = the paper's strict reading: an ambiguous chain says nothing).
        # Double stars closer than the centroid noise stay ambiguous whatever the pivots.
        self.max_ambiguous = int(max_ambiguous)
        self.max_rows = int(max_rows)  # a chain whose candidates outgrow this is dropped

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        n = min(self.config.max_stars, len(obs))
        if n < 3:
            return
        lookup = PairLookup(self.database.pairs, obs.vectors[:n], self.angle_tolerance(obs),
                            len(self.database.vectors), diag)
        budget = [self.max_lookups]
        # Each chain starts from another ordering of the stars: the first three of a triple
        # in spreading order, then the rest by brightness.
        for chain, start in enumerate(smart_triples(n)):
            if chain >= self.max_chains or budget[0] <= 0:
                break
            diag.extra["chains"] = chain + 1
            order = list(start) + [s for s in range(n) if s not in start]
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
        first = lookup(order[0], order[1])
        budget[0] -= 1
        if len(first) == 0:
            return None
        hyps, cols, skips = np.column_stack([first.cp, first.cq]), list(order[:2]), 0
        for q in order[2:]:
            if len(cols) >= 3 and len(hyps) == 1:
                break
            if budget[0] <= 0 or skips > self.max_skips:
                return None
            before = hyps
            budget[0] -= 1
            diag.pivots += 1
            hyps = join_extend(hyps, len(cols) - 1, lookup(cols[-1], q))
            for col_t in range(len(cols) - 1):
                if len(hyps) <= 1 or budget[0] <= 0:
                    break
                budget[0] -= 1
                diag.pivots += 1
                hyps = join_close(hyps, len(cols), col_t, lookup(q, cols[col_t]))
            if len(hyps) == 0 or len(hyps) > self.max_rows:
                hyps, skips = before, skips + 1
                diag.extra["skipped"] = diag.extra.get("skipped", 0) + 1
                continue
            cols.append(q)
        if len(cols) >= 3 and 1 <= len(hyps) <= max(self.max_ambiguous, 1):
            if len(hyps) > 1:
                diag.extra["ambiguous"] = diag.extra.get("ambiguous", 0) + 1
            return cols, hyps
        return None
