"""Catalog star pairs by inter-star angle, indexed with a k-vector."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from startrack._core._threads import usable_cores
from startrack._core.database import pair_tables as core_pairs
from startrack._core.sky import close_pairs
from startrack.database._kvector import KVector

#: the neighbour lists of :class:`startrack._core.database.pair_tables.PairNeighbours`, by name
LIST_KEYS = ("start_lo", "nbr_lo", "ang_lo", "start_hi", "nbr_hi", "ang_hi")


@dataclass(frozen=True)
class PairTable:
    """Every catalog pair (i < j) closer than ``max_angle``, sorted by angle (radians)."""

    i: np.ndarray  # int32 catalog rows
    j: np.ndarray  # int32 catalog rows
    angle: np.ndarray  # float64 radians, ascending
    kvector: KVector
    #: (n_catalog, the six neighbour lists) stored with the table
    #: (:func:`pair_index_arrays`), or None: built when first asked for
    lists: tuple | None = None

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


def pair_table_from_arrays(arrays: dict[str, np.ndarray],
                           index: dict[str, np.ndarray] | None = None) -> PairTable:
    """The table of ``arrays``; with ``index`` (:func:`pair_index_arrays` of them, as
    stored on disk) its k-vector and neighbour lists are read, not rebuilt."""
    if index is None:
        return PairTable(arrays["i"], arrays["j"], arrays["angle"],
                         KVector.build(arrays["angle"]))
    m, q = (float(v) for v in index["kvector_mq"])
    kvector = KVector(np.ascontiguousarray(arrays["angle"], np.float64), index["kvector_k"],
                      m, q)
    lists = (int(index["n_catalog"]), tuple(index[k] for k in LIST_KEYS))
    return PairTable(arrays["i"], arrays["j"], arrays["angle"], kvector, lists)


def pair_index_arrays(arrays: dict[str, np.ndarray], n_catalog: int) -> dict[str, np.ndarray]:
    """What a process would build from a pair table before its first search, to store
    beside it: the k-vector and the neighbour lists over ``n_catalog`` stars (0.3 to
    0.4 s a run for an 11 deg Hipparcos table; read from a mapped entry in milliseconds)."""
    kvector = KVector.build(arrays["angle"])
    built = core_pairs.PairNeighbours(arrays["i"], arrays["j"], arrays["angle"], n_catalog,
                                      threaded=build_threads(len(arrays["angle"])) > 1)
    return {"kvector_k": kvector.k, "kvector_mq": np.array([kvector.m, kvector.q]),
            "n_catalog": np.array(n_catalog), **dict(zip(LIST_KEYS, built.lists, strict=True))}


def select_pair_arrays(arrays: dict[str, np.ndarray], keep: np.ndarray) -> dict[str, np.ndarray]:
    """The pairs whose two stars both have ``keep`` set (a boolean mask over catalog rows),
    still sorted by angle: a pair table over a subset of the catalog, e.g. pattern stars."""
    sel = keep[arrays["i"]] & keep[arrays["j"]]
    return {"i": arrays["i"][sel], "j": arrays["j"][sel], "angle": arrays["angle"][sel]}

__all__ = ["LIST_KEYS", "PairTable", "build_pair_arrays", "build_threads",
           "pair_index_arrays", "pair_table_from_arrays", "select_pair_arrays"]
