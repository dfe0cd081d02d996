"""Catalog star pairs by inter-star angle, indexed with a k-vector."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from startrack._core import database as kernels
from startrack.database.kvector import KVector


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


def build_pair_arrays(vectors: np.ndarray, max_angle_rad: float) -> dict[str, np.ndarray]:
    """All pairs within ``max_angle_rad``, as arrays sorted by angle."""
    vectors = np.ascontiguousarray(vectors, dtype=np.float64).reshape(-1, 3)
    i, j, angle = kernels.sorted_close_pairs(vectors, float(max_angle_rad))
    return {"i": i, "j": j, "angle": angle}


def pair_table_from_arrays(arrays: dict[str, np.ndarray]) -> PairTable:
    return PairTable(arrays["i"], arrays["j"], arrays["angle"], KVector.build(arrays["angle"]))


def select_pair_arrays(arrays: dict[str, np.ndarray], keep: np.ndarray) -> dict[str, np.ndarray]:
    """The pairs whose two stars both have ``keep`` set (a boolean mask over catalog rows),
    still sorted by angle: a pair table over a subset of the catalog, e.g. pattern stars."""
    sel = keep[arrays["i"]] & keep[arrays["j"]]
    return {"i": arrays["i"][sel], "j": arrays["j"][sel], "angle": arrays["angle"][sel]}

__all__ = ["PairTable", "build_pair_arrays", "pair_table_from_arrays", "select_pair_arrays"]
