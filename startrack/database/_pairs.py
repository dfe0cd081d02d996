"""Catalog star pairs by inter-star angle, indexed with a k-vector."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from startrack._core._threads import usable_cores
from startrack._core.sky import close_pairs
from startrack.database._kvector import KVector


@dataclass(frozen=True)
class PairTable:
    """Every catalog pair (i < j) closer than ``max_angle``, sorted by angle (radians)."""

    i: np.ndarray  # int32 catalog rows
    j: np.ndarray  # int32 catalog rows
    angle: np.ndarray  # float64 radians, ascending
    kvector: KVector

    def __len__(self) -> int:
        return len(self.angle)

    def query(self, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(i, j, angle) of the pairs whose angle lies in [lo, hi]."""
        start, stop = self.kvector.range(lo, hi)
        return self.i[start:stop], self.j[start:stop], self.angle[start:stop]


#: a table of fewer pairs than this is built on one thread (threads cost more than it)
THREADED_PAIRS = 200_000
#: threads a table build uses at most
MAX_BUILD_THREADS = 8


def build_threads(pairs: float) -> int:
    """Threads for building a table of about ``pairs`` pairs: one for a small table, else
    one per core this process may use (a first run's table of millions of pairs takes a
    second or more on one; the threaded builds give the same arrays, bit for bit)."""
    if pairs < THREADED_PAIRS:
        return 1
    return min(usable_cores(), MAX_BUILD_THREADS)


def build_pair_arrays(vectors: np.ndarray, max_angle_rad: float) -> dict[str, np.ndarray]:
    """All pairs within ``max_angle_rad``, as arrays sorted by angle."""
    vectors = np.ascontiguousarray(vectors, dtype=np.float64).reshape(-1, 3)
    threads = build_threads(close_pairs.expected_pairs(len(vectors), max_angle_rad))
    i, j, angle = close_pairs.sorted_close_pairs(vectors, float(max_angle_rad), threads)
    return {"i": i, "j": j, "angle": angle}


def pair_table_from_arrays(arrays: dict[str, np.ndarray]) -> PairTable:
    return PairTable(arrays["i"], arrays["j"], arrays["angle"], KVector.build(arrays["angle"]))


def select_pair_arrays(arrays: dict[str, np.ndarray], keep: np.ndarray) -> dict[str, np.ndarray]:
    """The pairs whose two stars both have ``keep`` set (a boolean mask over catalog rows),
    still sorted by angle: a pair table over a subset of the catalog, e.g. pattern stars."""
    sel = keep[arrays["i"]] & keep[arrays["j"]]
    return {"i": arrays["i"][sel], "j": arrays["j"][sel], "angle": arrays["angle"][sel]}

__all__ = ["PairTable", "build_pair_arrays", "build_threads", "pair_table_from_arrays",
           "select_pair_arrays"]
