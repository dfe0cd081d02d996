"""Radial features (Zhang, Wei and Jiang 2008; the improved triangle paper): which rings
around a star hold a neighbour, as packed bits.

Around a star, the disc of angular radius R is cut into ``n_rings = ceil(R / dr)`` rings
of width dr; ring h covers angles [h dr, (h + 1) dr). Bit h of the feature is set when
some neighbour closer than R lies in ring h. Rows are ``np.packbits`` rows (bit h is
bit ``7 - h % 8`` of byte ``h // 8``), so a match score is an AND and a popcount.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack.database._pairs import PairTable

POPCOUNT = np.array([bin(b).count("1") for b in range(256)], dtype=np.uint8)
_SELF_RAD = 1e-7  # a neighbour at (numerically) zero angle is the star itself


def n_rings(radius_rad: float, ring_width_rad: float) -> int:
    return max(1, math.ceil(radius_rad / ring_width_rad - 1e-12))


def _check(radius_rad: float, ring_width_rad: float) -> None:
    if not (radius_rad > 0 and ring_width_rad > 0):
        raise ValueError("radial features need a positive radius and ring width")


def popcount_rows(packed: np.ndarray) -> np.ndarray:
    """Number of set bits in each packed row."""
    return POPCOUNT[packed].sum(axis=-1, dtype=np.int64)


def _pack(bits: np.ndarray) -> np.ndarray:
    return np.packbits(bits, axis=-1)


def radial_features(center_vectors: np.ndarray, neighbour_vectors: np.ndarray,
                    radius_rad: float, ring_width_rad: float) -> np.ndarray:
    """Packed radial feature (one uint8 row) of every centre among ``neighbour_vectors``.

    A neighbour at zero angle from a centre is taken to be the centre itself and skipped.
    """
    _check(radius_rad, ring_width_rad)
    nq = n_rings(radius_rad, ring_width_rad)
    c = np.atleast_2d(np.asarray(center_vectors, dtype=np.float64))
    nb = np.atleast_2d(np.asarray(neighbour_vectors, dtype=np.float64))
    angle = np.arccos(np.clip(c @ nb.T, -1.0, 1.0))
    ok = (angle < radius_rad) & (angle > _SELF_RAD)
    rows, cols = np.nonzero(ok)
    ring = np.minimum((angle[rows, cols] / ring_width_rad).astype(np.int64), nq - 1)
    bits = np.zeros((len(c), nq), dtype=bool)
    bits[rows, ring] = True
    return _pack(bits)


def observed_masks(vectors: np.ndarray, centers: np.ndarray, radius_rad: float,
                   ring_width_rad: float, tolerance_rad: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noise-tolerant radial features of observed stars ``centers`` (indices into
    ``vectors``), from every other observed star.

    A neighbour whose measured angle d lies farther than ``tolerance_rad`` from both edges
    of its ring h requires bit h of a catalog star (``single``). One within the tolerance
    of an edge is satisfied by either ring on the two sides of that edge: it goes into
    ``double`` at the lower ring h', meaning "bit h' or h' + 1" (when both edges are that
    close, the nearer one wins). A neighbour that may lie either side of R is left out,
    since the catalog star may or may not count it. Returns packed ``single`` and
    ``double`` rows and ``need``, the number of requirements of each centre.
    """
    _check(radius_rad, ring_width_rad)
    nq = n_rings(radius_rad, ring_width_rad)
    v = np.asarray(vectors, dtype=np.float64)
    centers = np.asarray(centers, dtype=np.int64)
    d = np.arccos(np.clip(v[centers] @ v.T, -1.0, 1.0))
    d[np.arange(len(centers)), centers] = np.inf
    ok = d + tolerance_rad < radius_rad
    h = np.minimum(np.floor(d / ring_width_rad), nq - 1).astype(np.int64)
    h = np.where(ok, h, 0)
    below = d - h * ring_width_rad  # distance to the ring's lower edge
    above = (h + 1) * ring_width_rad - d
    low_edge = (below < tolerance_rad) & (h > 0) & (below <= above)
    high_edge = (above < tolerance_rad) & ~low_edge
    is_double = ok & (low_edge | high_edge)
    start = np.where(low_edge, h - 1, h)
    single = np.zeros((len(centers), nq), dtype=bool)
    double = np.zeros((len(centers), nq), dtype=bool)
    r, c = np.nonzero(ok & ~is_double)
    single[r, h[r, c]] = True
    r, c = np.nonzero(is_double)
    double[r, start[r, c]] = True
    need = single.sum(axis=1) + double.sum(axis=1)
    return _pack(single), _pack(double), need.astype(np.int64)


def build_radial_arrays(pairs: PairTable, n_stars: int, radius_rad: float,
                        ring_width_rad: float) -> dict[str, np.ndarray]:
    """Packed radial feature of every catalog star, its neighbours taken from the pair
    table (``radius_rad`` must not exceed the table's largest angle)."""
    _check(radius_rad, ring_width_rad)
    nq = n_rings(radius_rad, ring_width_rad)
    stop = int(np.searchsorted(pairs.angle, radius_rad, side="left"))
    angle = pairs.angle[:stop]
    keep = angle > _SELF_RAD
    ring = np.minimum((angle[keep] / ring_width_rad).astype(np.int64), nq - 1)
    flat = np.zeros(n_stars * nq, dtype=bool)
    # Each pair sets the same ring for both of its stars.
    flat[pairs.i[:stop][keep].astype(np.int64) * nq + ring] = True
    flat[pairs.j[:stop][keep].astype(np.int64) * nq + ring] = True
    return {"bits": _pack(flat.reshape(n_stars, nq))}


@dataclass(frozen=True)
class RadialTable:
    """Radial features of all catalog stars (row = catalog row).

    ``spread`` has bit h set when ``bits`` has bit h or h + 1: one AND with it answers
    "either ring" requirements from :func:`observed_masks`.
    """

    bits: np.ndarray  # (N, n_bytes) uint8
    spread: np.ndarray  # (N, n_bytes) uint8
    count: np.ndarray  # set bits per row
    radius_rad: float
    ring_width_rad: float
    fill: np.ndarray  # share of rings set, per row
    spread_fill: np.ndarray  # the same for ``spread``

    @property
    def n_rings(self) -> int:
        return n_rings(self.radius_rad, self.ring_width_rad)

    def scores(self, single: np.ndarray, double: np.ndarray) -> np.ndarray:
        """l for every catalog star: the requirements of one observed feature it meets."""
        l1, l2 = self._split_scores(single, double)
        return l1 + l2

    def _split_scores(self, single: np.ndarray, double: np.ndarray,
                      among: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        out = []
        for table, mask in ((self.bits, single), (self.spread, double)):
            table = table if among is None else table[among]
            cols = np.flatnonzero(mask)  # only bytes the observed star uses
            l = np.zeros(len(table), dtype=np.int64)
            if len(cols):
                l += POPCOUNT[table[:, cols] & mask[cols]].sum(axis=1, dtype=np.int64)
            out.append(l)
        return out[0], out[1]

    def shortlist(self, single: np.ndarray, double: np.ndarray, need: int,
                  frac: float = 0.75, cap: int = 10, hit_rate: float = 0.9,
                  among: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Catalog rows with l >= frac * need (the paper's rule), the ``cap`` most likely
        first. A crowded catalog star meets requirements by chance, so rows are ranked by
        the log-likelihood ratio of "same star" (each requirement met with probability
        ``hit_rate``) against "unrelated" (met with the row's share of set bits).
        ``among``: only these catalog rows are candidates (a known sky patch).
        Returns (rows, l)."""
        l1, l2 = self._split_scores(single, double, among)
        l = l1 + l2
        rows = np.flatnonzero(l >= max(1, math.ceil(frac * need - 1e-9)))
        if len(rows) == 0:
            return rows, l[rows]
        n1, n2 = int(popcount_rows(single)), int(popcount_rows(double))
        key = np.zeros(len(rows))
        for n_req, hits, fill in ((n1, l1, self.fill), (n2, l2, self.spread_fill)):
            fill = fill if among is None else fill[among]
            p = np.clip(fill[rows], 0.01, 0.99)
            key += (hits[rows] * np.log(hit_rate / p)
                    + (n_req - hits[rows]) * np.log((1.0 - hit_rate) / (1.0 - p)))
        if len(rows) > cap:
            top = np.argpartition(-key, cap - 1)[:cap]
            rows, key = rows[top], key[top]
        order = np.argsort(-key, kind="stable")
        found = rows[order] if among is None else np.asarray(among)[rows[order]]
        return found, l[rows[order]]

def radial_table_from_arrays(arrays: dict[str, np.ndarray], radius_rad: float,
                             ring_width_rad: float) -> RadialTable:
    bits = arrays["bits"]
    nq = n_rings(radius_rad, ring_width_rad)
    unpacked = np.unpackbits(bits, axis=1, count=nq).astype(bool)
    spread = unpacked.copy()
    spread[:, :-1] |= unpacked[:, 1:]
    count = popcount_rows(bits)
    return RadialTable(bits, _pack(spread), count, float(radius_rad), float(ring_width_rad),
                       count / nq, spread.sum(axis=1) / nq)

__all__ = [
    "POPCOUNT", "RadialTable", "build_radial_arrays", "n_rings", "observed_masks",
    "popcount_rows", "radial_features", "radial_table_from_arrays",
]
