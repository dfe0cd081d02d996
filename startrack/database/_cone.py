"""Catalog rows within a cone of the sky: declination bands of stars sorted by right
ascension, searched over the bands and the RA span the cone covers, then a dot-product
test (compiled: :func:`startrack._core.verify.entry_points.cone_rows`).

Verification looks up one cone per hypothesis, so the lookup must cost microseconds, not
the ~0.1 ms of a k-d tree ball query with its Python overhead; the bands' RA windows hold
little more than the cone itself, where a single declination band held ten times more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack._core.verify.entry_points import ConeTable, cone_rows

BAND_RAD = math.radians(1.0)  # declination band height
# Windows are widened by this (radians) so that rounding never drops a star on an edge;
# the dot test decides.
EDGE = 1e-9


@dataclass(frozen=True)
class ConeIndex:
    """Unit vectors (n, 3) and their rows by declination band, then right ascension;
    ``table`` holds the same arrays for the compiled lookups."""

    vectors: np.ndarray
    order: np.ndarray
    ra_sorted: np.ndarray
    band_start: np.ndarray
    table: ConeTable

    @classmethod
    def build(cls, vectors: np.ndarray) -> ConeIndex:
        vectors = np.ascontiguousarray(vectors, dtype=np.float64)
        n_bands = int(math.ceil(math.pi / BAND_RAD))
        dec = np.arcsin(np.clip(vectors[:, 2], -1.0, 1.0))
        ra = np.arctan2(vectors[:, 1], vectors[:, 0]) % (2.0 * math.pi)
        band = np.minimum(((dec + math.pi / 2.0) / BAND_RAD).astype(np.int64), n_bands - 1)
        order = np.lexsort((ra, band)).astype(np.int64)
        band_start = np.searchsorted(band[order], np.arange(n_bands + 1)).astype(np.int64)
        ra_sorted = np.ascontiguousarray(ra[order])
        return cls(vectors, order, ra_sorted, band_start,
                   ConeTable(vectors, order, ra_sorted, band_start))

    def prefix(self, n: int) -> ConeIndex:
        """The index of the first ``n`` rows (a magnitude cut of a brightest-first
        catalog): the same bands and order with the later rows left out, which is what
        :meth:`build` makes of them, without its sort of every star."""
        keep = self.order < n
        kept_before = np.concatenate([[0], np.cumsum(keep)]).astype(np.int64)
        vectors = self.vectors[:n]
        order = np.ascontiguousarray(self.order[keep])
        ra_sorted = np.ascontiguousarray(self.ra_sorted[keep])
        band_start = np.ascontiguousarray(kept_before[self.band_start])
        return ConeIndex(vectors, order, ra_sorted, band_start,
                         ConeTable(vectors, order, ra_sorted, band_start))

    def rows(self, direction: np.ndarray, radius_rad: float) -> np.ndarray:
        """Rows within ``radius_rad`` of the unit vector ``direction``, ascending."""
        direction = np.ascontiguousarray(direction, dtype=np.float64)
        return cone_rows(self.table, direction, min(float(radius_rad), math.pi))


    @property
    def nbytes(self) -> int:
        """The bytes of its own arrays (its vectors are the catalog's)."""
        return self.order.nbytes + self.ra_sorted.nbytes + self.band_start.nbytes


class CutCones:
    """The cone indexes of a brightest-first catalog's magnitude cuts (its first ``n``
    rows), each cut from the whole catalog's index (:meth:`ConeIndex.prefix`), the
    latest kept while together they fit in ``max_bytes``: a blind search cuts the same
    few per frame, and each cut filters every star of the whole catalog (2 ms for
    Gaia's 480,000, most of a blind solve when the cuts were made again per frame)."""

    def __init__(self, whole: ConeIndex, max_bytes: int) -> None:
        self.whole = whole  # the index of every row, which each cut filters
        self.max_bytes = int(max_bytes)
        self._cuts: dict[int, ConeIndex] = {}

    def cut(self, n: int) -> ConeIndex:
        """The index of the first ``n`` rows."""
        cone = self._cuts.pop(n, None) or self.whole.prefix(n)
        if cone.nbytes <= self.max_bytes:
            while self._cuts and cone.nbytes + sum(
                    c.nbytes for c in self._cuts.values()) > self.max_bytes:
                self._cuts.pop(next(iter(self._cuts)))  # the least recently used
            self._cuts[n] = cone
        return cone


def cone_index_of(catalog) -> ConeIndex:
    """The cone index of every row of ``catalog``, built on first use and held by it: one
    per catalog, whatever its databases, blind searches and refits."""
    held = catalog.__dict__.get("_cone_index")
    if held is None:
        held = catalog.__dict__["_cone_index"] = ConeIndex.build(catalog.vectors)
    return held


def held_cone_index(catalog) -> ConeIndex | None:
    """:func:`cone_index_of` where something already built it, else None: building one
    sorts the whole catalog, which a caller wanting a few rows would not repay."""
    return catalog.__dict__.get("_cone_index")


__all__ = ["BAND_RAD", "ConeIndex", "CutCones", "EDGE", "cone_index_of", "cone_rows",
           "held_cone_index"]
