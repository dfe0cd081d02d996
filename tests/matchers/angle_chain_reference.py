"""The angle matcher's chain search as it ran in Python before it was compiled
(startrack._core.matchers.angle): pair lookups and joins through
startrack.matchers._shared.pair_joins, the chains orchestrated here. Kept as the reference that
tests/matchers/test_angle_search.py holds the compiled search to: the same hypotheses in the same
order, the same diagnostics."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._angle import AngleMatcher
from startrack.matchers._shared.pair_joins import PairLookup, join_close, join_extend, pair_index
from startrack.matchers._shared.triples import triple_order


def reference_hypotheses(m: AngleMatcher, obs: Observation,
                         diag: MatchDiagnostics) -> Iterator[Hypothesis]:
    """``m.hypotheses(obs, diag)`` as the Python chain search gave them."""
    n = min(m.config.max_stars + max(m.extra_stars, 0), len(obs))
    if n < 3:
        return
    first = min(m.config.max_stars, n)
    index = pair_index(m._table(), len(m.database.vectors))
    lookup = PairLookup(index, obs.vectors[:n], m.angle_tolerance(obs), diag)
    budget = [m.max_lookups]
    for chain, start in enumerate(triple_order(first, n, m.max_chains)):
        if budget[0] <= 0:
            break
        diag.extra["chains"] = chain + 1
        stars = range(max(first, start[2] + 1))
        order = list(start) + [s for s in stars if s not in start]
        found = _chain(m, order, lookup, diag, budget)
        if found is not None:
            cols, rows = found
            for row in rows:
                yield Hypothesis(np.asarray(cols, np.int64), row.astype(np.int64))


def _chain(m: AngleMatcher, order: list[int], lookup: PairLookup, diag: MatchDiagnostics,
           budget: list[int]) -> tuple[list[int], np.ndarray] | None:
    hyps = lookup.pairs(order[0], order[1])
    budget[0] -= 1
    if len(hyps) == 0:
        return None
    cols, skips = list(order[:2]), 0
    for q in order[2:]:
        if len(cols) >= 3 and len(hyps) == 1:
            break
        if budget[0] <= 0 or skips > m.max_skips:
            return None
        before = hyps
        budget[0] -= 1
        diag.pivots += 1
        hyps, total = join_extend(hyps, len(cols) - 1, lookup, cols[-1], q, m.max_rows + 1)
        for col_t in range(len(cols) - 1 if m.closing != "none" else 0):
            if budget[0] <= 0 or total > m.max_rows or len(hyps) == 0 or (
                    len(hyps) == 1 and m.closing == "until_one"):
                break
            budget[0] -= 1
            diag.pivots += 1
            hyps = join_close(hyps, len(cols), col_t, lookup, q, cols[col_t])
        if len(hyps) == 0 or total > m.max_rows:
            hyps, skips = before, skips + 1
            diag.extra["skipped"] = diag.extra.get("skipped", 0) + 1
            continue
        cols.append(q)
    if len(cols) >= 3 and 1 <= len(hyps) <= max(m.max_ambiguous, 1):
        if len(hyps) > 1:
            diag.extra["ambiguous"] = diag.extra.get("ambiguous", 0) + 1
        return cols, hyps
    return None
