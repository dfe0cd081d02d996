"""Pair lookups and joins on a catalog pair table, for the observed pairs of one frame.

A hypothesis table holds rows of catalog stars, one column per observed star. Joins grow
it by a pair lookup that shares a star with it (:func:`join_extend`) or narrow it by a
pair between two of its stars (:func:`join_close`); both run compiled over the table's
neighbour lists (:mod:`startrack._core.database.pair_tables`), never materialising
the lookup.
"""

from __future__ import annotations

import numpy as np

from startrack._core.database import pair_tables as core
from startrack.database import PairTable, build_threads
from startrack.match_records import MatchDiagnostics
from startrack.matchers._shared.geometry import angle_table


class PairIndex:
    """A pair table with its neighbour lists (built once per table, compiled)."""

    def __init__(self, table: PairTable, n_catalog: int) -> None:
        self.table = table
        self.n_catalog = int(n_catalog)
        self.pi = np.ascontiguousarray(table.i, dtype=np.int32)
        self.pj = np.ascontiguousarray(table.j, dtype=np.int32)
        self.angle = np.ascontiguousarray(table.angle, dtype=np.float64)
        #: the table and its neighbour lists, as the compiled searches take them
        stored = table.lists[1] if table.lists and table.lists[0] == self.n_catalog else None
        self.neighbours = core.PairNeighbours(self.pi, self.pj, self.angle, self.n_catalog,
                                              threaded=build_threads(len(self.pi)) > 1,
                                              lists=stored)
        #: (start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi): the lists as arrays
        self.lists = self.neighbours.lists

    @property
    def arrays(self) -> tuple:
        """(pi, pj, angle, *lists): the table and its neighbour lists."""
        return (self.pi, self.pj, self.angle, *self.lists)

    def window(self, lo: float, hi: float) -> tuple[int, int]:
        """Table entries [start, stop) with angle in [lo, hi]."""
        return (int(np.searchsorted(self.angle, lo, side="left")),
                int(np.searchsorted(self.angle, hi, side="right")))


def pair_index(table: PairTable, n_catalog: int) -> PairIndex:
    """The :class:`PairIndex` of ``table``, built the first time it is asked for."""
    # Kept on the (frozen) table itself, so it lives and dies with it.
    cache = table.__dict__.setdefault("_pair_index", {})
    if n_catalog not in cache:
        cache[n_catalog] = PairIndex(table, n_catalog)
    return cache[n_catalog]


class PairLookup:
    """Catalog pair windows for the observed pairs of one frame.

    The observed pair (p, q) stands for every table pair whose angle lies within ``tol``
    of the observed angle, in both orientations. Only first lookups of a pair count as
    database candidates (``diag.candidates``, ``diag.extra["lookups"]``).
    """

    def __init__(self, index: PairIndex, vectors: np.ndarray, tol: float,
                 diag: MatchDiagnostics) -> None:
        self.index = index
        self.angles = angle_table(vectors)
        self.tol = float(tol)
        self.diag = diag
        self._seen: set[tuple[int, int]] = set()
        self._grouped: dict[tuple[int, int], tuple[np.ndarray, ...]] = {}

    def window(self, p: int, q: int) -> tuple[float, float]:
        """The angle window [lo, hi] of the observed pair (p, q)."""
        theta = float(self.angles[p, q])
        key = (min(p, q), max(p, q))
        if key not in self._seen:
            self._seen.add(key)
            start, stop = self.index.window(theta - self.tol, theta + self.tol)
            self.diag.candidates += stop - start
            self.diag.extra["lookups"] = self.diag.extra.get("lookups", 0) + 1
        return theta - self.tol, theta + self.tol

    def grouped(self, p: int, q: int) -> tuple[np.ndarray, ...] | None:
        """The pairs of (p, q) linked per catalog star of p (see
        :func:`startrack._core.database.pair_tables.group_pairs`), built once per frame; None
        when there
        are none."""
        if (p, q) not in self._grouped:
            start, stop = self.index.window(*self.window(p, q))
            self._grouped[p, q] = None if stop <= start else core.group_pairs(
                self.index.neighbours, start, stop, p > q)
        return self._grouped[p, q]

    def grouped_either(self, p: int, q: int) -> tuple[np.ndarray, ...] | None:
        """A grouping of (p, q) for a membership test: the pair set is the same both ways
        round, so whichever one exists serves."""
        return self.grouped(q, p) if (q, p) in self._grouped else self.grouped(p, q)

    def pairs(self, p: int, q: int) -> np.ndarray:
        """The catalog pairs of (p, q) as (K x 2) rows (star of p, star of q): the table
        order one way round, then the other."""
        lo, hi = self.window(p, q)
        start, stop = self.index.window(lo, hi)
        i = self.index.pi[start:stop].astype(np.int64)
        j = self.index.pj[start:stop].astype(np.int64)
        if p > q:
            i, j = j, i
        return np.column_stack([np.concatenate([i, j]), np.concatenate([j, i])])


def join_extend(hyps: np.ndarray, col: int, lookup: PairLookup, p: int, q: int,
                max_rows: int = 2_000_000) -> tuple[np.ndarray, int]:
    """Join on a shared star: every row whose column ``col`` (observed star p) has a
    partner in the lookup of (p, q) becomes one row per partner, the partner appended;
    rows that would use a catalog star twice go. Returns (rows, total joined rows); at
    most ``max_rows`` rows are kept."""
    grouped = lookup.grouped(p, q)
    hyps = np.ascontiguousarray(hyps, dtype=np.int64)
    if len(hyps) == 0 or grouped is None:
        return np.zeros((0, hyps.shape[1] + 1), np.int64), 0
    rows, total = core.join_extend(hyps, col, *grouped, max_rows)
    return rows, int(total)


def join_close(hyps: np.ndarray, col_p: int, col_q: int, lookup: PairLookup, p: int,
               q: int) -> np.ndarray:
    """Keep the rows whose catalog stars in columns (col_p, col_q) are a candidate pair of
    the observed pair (p, q)."""
    grouped = lookup.grouped_either(p, q)
    hyps = np.ascontiguousarray(hyps, dtype=np.int64)
    if len(hyps) == 0 or grouped is None:
        return hyps[:0]
    return core.join_close(hyps, col_p, col_q, *grouped)


def join_sorted(left: np.ndarray, left_cols: tuple[int, ...], right: np.ndarray,
                distinct: bool = True) -> np.ndarray:
    """Sorted-key join: each row of ``left`` (M x s) once per row of ``right``
    (K x (c + 1)) whose first c columns equal the row's columns ``left_cols``, that right
    row's last column appended (right rows in their own order). With ``distinct`` a row
    whose new value is already in it goes."""
    width = left.shape[1] + 1
    if len(left) == 0 or len(right) == 0:
        return np.zeros((0, width), np.int64)
    base = int(max(left.max(), right.max())) + 1
    key_l = np.zeros(len(left), np.int64)
    key_r = np.zeros(len(right), np.int64)
    for n, col in enumerate(left_cols):
        key_l = key_l * base + left[:, col]
        key_r = key_r * base + right[:, n]
    order = np.argsort(key_r, kind="stable")
    keys = key_r[order]
    lo = np.searchsorted(keys, key_l, side="left")
    count = np.searchsorted(keys, key_l, side="right") - lo
    rows = np.repeat(np.arange(len(left)), count)
    pos = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
    out = np.column_stack([left[rows], right[order[pos], -1]]).astype(np.int64)
    if distinct:
        out = out[np.all(out[:, :-1] != out[:, -1:], axis=1)]
    return out


def member_pairs(a: np.ndarray, b: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Whether each (a[m], b[m]) is a row of ``pairs`` (K x 2), by sorted keys."""
    if len(pairs) == 0 or len(a) == 0:
        return np.zeros(len(a), bool)
    base = int(max(pairs.max(), a.max(), b.max())) + 1
    keys = np.sort(pairs[:, 0].astype(np.int64) * base + pairs[:, 1])
    want = np.asarray(a, np.int64) * base + b
    pos = np.minimum(np.searchsorted(keys, want), len(keys) - 1)
    return keys[pos] == want


def compact_pairs(pi: np.ndarray, pj: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pair table's stars renumbered 0, 1, ... (their "slots"): (pi, pj) as slots, and
    the catalog row of each slot. The angle search runs on slots, so that its per-pair
    grouping heads span the table's stars, not the whole catalog; equality of stars, all
    the joins ask of them, is the same on either numbering."""
    rows, inverse = np.unique(np.concatenate([pi, pj]), return_inverse=True)
    inverse = inverse.astype(np.int32)
    return inverse[:len(pi)].copy(), inverse[len(pi):].copy(), rows.astype(np.int64)

__all__ = [
    "PairIndex", "PairLookup", "compact_pairs", "join_close", "join_extend", "join_sorted",
    "member_pairs", "pair_index",
]
