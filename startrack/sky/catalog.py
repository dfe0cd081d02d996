"""The star catalog as arrays, with the cuts every sky shares (magnitude, close pairs)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree


def radec_to_vectors(ra_deg: np.ndarray, dec_deg: np.ndarray) -> np.ndarray:
    """ICRS unit vectors (N x 3) from RA/Dec in degrees."""
    ra = np.radians(np.asarray(ra_deg, dtype=np.float64))
    dec = np.radians(np.asarray(dec_deg, dtype=np.float64))
    cd = np.cos(dec)
    return np.stack([cd * np.cos(ra), cd * np.sin(ra), np.sin(dec)], axis=-1)


def vectors_to_radec(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RA in [0, 360) and Dec in degrees from unit vectors (N x 3)."""
    v = np.asarray(v, dtype=np.float64)
    ra = np.degrees(np.arctan2(v[..., 1], v[..., 0])) % 360.0
    dec = np.degrees(np.arcsin(np.clip(v[..., 2], -1.0, 1.0)))
    return ra, dec


class BadId(ValueError):
    """A catalog id that is not an exact 64-bit integer; ``row`` is its 0-based row."""

    def __init__(self, row: int, message: str) -> None:
        super().__init__(message)
        self.row = row


def exact_ids(values: np.ndarray) -> np.ndarray:
    """A column of catalog ids (integers, floats or text) as exact int64: never through
    float64, whose 53-bit mantissa merges Gaia source ids (ids differing by 1 would
    become repeats). Raises :class:`BadId` naming the first bad row."""
    values = np.asarray(values)
    kind = values.dtype.kind
    if kind == "b":
        raise BadId(0, "id must be an integer, not true/false")
    if kind in "iu":
        big = np.flatnonzero(values > np.iinfo(np.int64).max) if kind == "u" else []
        if len(big):
            raise BadId(int(big[0]), f"id {values[big[0]]} is beyond 64-bit integers")
        return values.astype(np.int64)
    if kind == "f":  # a float column holds an id exactly only up to 2**53
        bad = np.flatnonzero(~np.isfinite(values) | (values != np.round(values))
                             | (np.abs(values) > 2.0**53))
        if len(bad):
            raise BadId(int(bad[0]), f"id {values[bad[0]]!r} is not an integer a float "
                        "column holds exactly (store ids as integers)")
        return values.astype(np.int64)
    try:  # text cells, parsed as integers (exact at any size)
        return np.char.strip(values.astype("U")).astype(np.int64)
    except (ValueError, OverflowError, TypeError):  # only then, row by row, to name the bad one
        return np.array([_id_cell(row, cell) for row, cell in enumerate(values)],
                        dtype=np.int64)


def _id_cell(row: int, cell) -> int:
    text = str(cell).strip()
    try:
        value = int(text)
    except ValueError:
        try:
            number = float(text)
        except ValueError:
            number = float("nan")
        if not (np.isfinite(number) and number == round(number) and abs(number) <= 2.0**53):
            raise BadId(row, f"id {cell!r} is not an integer") from None
        value = int(number)
    if not -(2**63) <= value < 2**63:
        raise BadId(row, f"id {cell!r} is beyond 64-bit integers")
    return value


@dataclass(frozen=True)
class Catalog:
    """Stars sorted brightest first.

    ``ids`` are the user-facing identifiers (HIP numbers, or 0..N-1 for a random sky);
    every other stage addresses stars by their row index in these arrays.
    ``source`` is the sky specification that rebuilds this exact catalog.
    """

    ids: np.ndarray  # int64
    ra_deg: np.ndarray
    dec_deg: np.ndarray
    mag: np.ndarray
    source: dict = field(default_factory=dict)
    vectors: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        order = np.argsort(self.mag, kind="stable")
        for name in ("ids", "ra_deg", "dec_deg", "mag"):
            arr = np.ascontiguousarray(np.asarray(getattr(self, name))[order])
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "vectors", radec_to_vectors(self.ra_deg, self.dec_deg))

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, mask_or_index: np.ndarray) -> Catalog:
        """A catalog of the selected rows, keeping the source description."""
        return Catalog(
            ids=self.ids[mask_or_index],
            ra_deg=self.ra_deg[mask_or_index],
            dec_deg=self.dec_deg[mask_or_index],
            mag=self.mag[mask_or_index],
            source=dict(self.source),
        )

    def fingerprint(self) -> str:
        """A short hash of the catalog's content, for cache keys."""
        h = hashlib.sha256()
        for arr in (self.ids, self.vectors, self.mag):
            h.update(np.ascontiguousarray(arr).tobytes())
        return h.hexdigest()[:16]

    def index_of(self, ids: np.ndarray) -> np.ndarray:
        """Row indices of the given ids (-1 where absent)."""
        ids = np.asarray(ids, dtype=np.int64)
        order = np.argsort(self.ids)
        pos = np.searchsorted(self.ids, ids, sorter=order)
        pos = np.clip(pos, 0, len(self.ids) - 1)
        rows = order[pos]
        return np.where(self.ids[rows] == ids, rows, -1)


def cut_magnitude(catalog: Catalog, mag_limit: float | None) -> Catalog:
    """Stars at or brighter than ``mag_limit`` (all when None)."""
    if mag_limit is None:
        return catalog
    return catalog.subset(catalog.mag <= mag_limit)


def merge_close_stars(catalog: Catalog, min_separation_deg: float) -> Catalog:
    """Drop every star that lies within ``min_separation_deg`` of a brighter kept star.

    The optics cannot split such pairs; the blend is seen as the brighter star, so the
    brighter one is kept with its own position and magnitude.
    """
    if min_separation_deg <= 0 or len(catalog) < 2:
        return catalog
    chord = 2.0 * np.sin(np.radians(min_separation_deg) / 2.0)
    tree = cKDTree(catalog.vectors)
    pairs = tree.query_pairs(chord, output_type="ndarray")
    if len(pairs) == 0:
        return catalog
    # Rows are sorted brightest first, so in each pair the smaller row is the brighter.
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    keep = np.ones(len(catalog), dtype=bool)
    # Greedy in brightness order: a star removed by a brighter neighbour cannot remove others.
    # Only stars that take part in a close pair are visited, a small fraction of the sky.
    for a, b in pairs:
        if keep[a]:
            keep[b] = False
    return catalog.subset(keep)

__all__ = ["BadId", "Catalog", "cut_magnitude", "exact_ids", "merge_close_stars",
           "radec_to_vectors", "vectors_to_radec"]
