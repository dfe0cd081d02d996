"""The k-vector (Mortari 1997): O(1) range queries on a sorted array of feature values."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from startrack._core.database import builds as kernels
from startrack._core.shared import kvector_range


@dataclass(frozen=True)
class KVector:
    """Sorted values with Mortari's k-vector over them.

    With sorted ``values`` s[0..n-1], the line z(i) = m*i + q runs through
    (0, s[0] - eps) and (n-1, s[n-1] + eps), and k[i] counts the values <= z(i). A query
    [lo, hi] reads two entries of k and trims the slice at its ends, so its cost does not
    grow with n.
    """

    values: np.ndarray
    k: np.ndarray
    m: float
    q: float

    @classmethod
    def build(cls, sorted_values: np.ndarray) -> KVector:
        s = np.ascontiguousarray(sorted_values, dtype=np.float64)
        if s.ndim != 1:
            raise ValueError("k-vector needs a 1-D array")
        n = len(s)
        if n == 0:
            return cls(s, np.zeros(1, np.int64), 1.0, 0.0)
        if not kernels.is_sorted(s):
            raise ValueError("k-vector needs sorted values")
        eps = max(np.finfo(np.float64).eps * max(abs(s[0]), abs(s[-1]), 1.0) * 4, 1e-15)
        lo, hi = s[0] - eps, s[-1] + eps
        m = (hi - lo) / max(n - 1, 1)
        q = lo
        # np.searchsorted(s, m * np.arange(n) + q, side="right"), by one merge.
        k = kernels.count_at_most(s, float(m), float(q))
        return cls(s, k, float(m), float(q))

    def __len__(self) -> int:
        return len(self.values)

    def range(self, lo: float, hi: float) -> tuple[int, int]:
        """Positions [start, stop) of the sorted values within [lo, hi]
        (the compiled core's k-vector range)."""
        start, stop = kvector_range(self.values, self.k, self.m, self.q, float(lo), float(hi))
        return int(start), int(stop)


def binary_search_range(sorted_values: np.ndarray, lo: float, hi: float) -> tuple[int, int]:
    """The same answer as ``KVector.range`` by binary search: the baseline to test against."""
    s = sorted_values
    return int(np.searchsorted(s, lo, side="left")), int(np.searchsorted(s, hi, side="right"))

__all__ = ["KVector", "binary_search_range"]
