"""The star catalog as arrays, with the cuts every sky shares (magnitude, close pairs)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import xxhash
from scipy.spatial import cKDTree

from startrack.io import cached_arrays


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
        mag = np.asarray(self.mag)
        # a catalog read from the cache is sorted already: a deep one's sort costs seconds
        order = None if bool(np.all(mag[1:] >= mag[:-1])) else np.argsort(mag, kind="stable")
        for name in ("ids", "ra_deg", "dec_deg", "mag"):
            arr = np.asarray(getattr(self, name))
            arr = np.ascontiguousarray(arr if order is None else arr[order])
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "vectors", radec_to_vectors(self.ra_deg, self.dec_deg))

    def __len__(self) -> int:
        return len(self.ids)

    def __getstate__(self) -> dict:
        """Its fields alone when pickled: what later stages hold on it (``_``: its cone
        indexes, fingerprints) is theirs to make again, and a compiled index has no
        pickle."""
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_")}

    def subset(self, mask_or_index: np.ndarray) -> Catalog:
        """A catalog of the selected rows, keeping the source description (and the rows'
        unit vectors: converting a deep catalog's positions again costs a second)."""
        picked = {name: getattr(self, name)[mask_or_index]
                  for name in ("ids", "ra_deg", "dec_deg", "mag", "vectors")}
        mag = picked["mag"]
        if not bool(np.all(mag[1:] >= mag[:-1])):  # rows picked out of order
            order = np.argsort(mag, kind="stable")
            picked = {name: arr[order] for name, arr in picked.items()}
        cut = object.__new__(Catalog)
        for name, arr in picked.items():
            object.__setattr__(cut, name, np.ascontiguousarray(arr))
        object.__setattr__(cut, "source", dict(self.source))
        return cut

    def head(self, n: int) -> Catalog:
        """The brightest ``n`` stars (a magnitude cut), sharing this catalog's arrays and
        unit vectors (no copy, no conversion)."""
        cut = object.__new__(Catalog)
        for name in ("ids", "ra_deg", "dec_deg", "mag", "vectors"):
            object.__setattr__(cut, name, getattr(self, name)[:n])
        object.__setattr__(cut, "source", dict(self.source))
        return cut

    def fingerprint(self, rows: int | None = None) -> str:
        """A short hash of the catalog's content, for cache keys (computed once: XXH3
        reads a deep catalog's arrays in milliseconds, where SHA-256 took a second).
        ``rows``: of its first (brightest) rows only, which every magnitude cut of the
        same catalog holding them shares: a table made of them serves every such cut."""
        rows = len(self) if rows is None else min(int(rows), len(self))
        prints = self.__dict__.setdefault("_fingerprints", {})
        if rows not in prints:
            h = xxhash.xxh3_128()
            for arr in (self.ids, self.vectors, self.mag):
                h.update(np.ascontiguousarray(arr[:rows]).reshape(-1).view(np.uint8))
            prints[rows] = h.hexdigest()[:16]
        return prints[rows]

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


#: a catalog this large has its merge kept in the disk cache (a deep catalog's pairs take
#: seconds to find, on every run of the same camera)
CACHED_MERGE_STARS = 100_000


def merge_close_stars(catalog: Catalog, min_separation_deg: float) -> Catalog:
    """Drop every star that lies within ``min_separation_deg`` of a brighter kept star.

    The optics cannot split such pairs; the blend is seen as the brighter star, so the
    brighter one is kept with its own position and magnitude.
    """
    if min_separation_deg <= 0 or len(catalog) < 2:
        return catalog
    if len(catalog) < CACHED_MERGE_STARS:
        keep = _kept_apart(catalog.vectors, min_separation_deg)
    else:
        keep = cached_arrays("merged", {"catalog": catalog.fingerprint(),
                                        "separation_deg": round(float(min_separation_deg), 12)},
                             lambda: {"keep": _kept_apart(catalog.vectors,
                                                          min_separation_deg)})["keep"]
    return catalog if bool(np.all(keep)) else catalog.subset(np.asarray(keep))


def _kept_apart(vectors: np.ndarray, min_separation_deg: float) -> np.ndarray:
    """:func:`merge_close_stars`' rows kept (rows brightest first)."""
    chord = 2.0 * np.sin(np.radians(min_separation_deg) / 2.0)
    pairs = cKDTree(vectors).query_pairs(chord, output_type="ndarray")
    if len(pairs) == 0:
        return np.ones(len(vectors), dtype=bool)
    # Rows are sorted brightest first, so in each pair the smaller row is the brighter.
    pairs = np.sort(pairs, axis=1)
    return kept_in_brightness_order(pairs[:, 0], pairs[:, 1], len(vectors))


def kept_in_brightness_order(brighter: np.ndarray, fainter: np.ndarray, n: int) -> np.ndarray:
    """Which of ``n`` rows stay when, in brightness order (row order), each kept row
    removes the fainter rows it is paired with: a row removed by a brighter one removes
    no other. Computed as the fixed point of "kept unless a kept brighter partner", which
    a row reaches once every row before it has, so the loop runs as many times as the
    longest chain of partners is long (a few: close pairs seldom chain), each vectorised."""
    keep = np.ones(n, dtype=bool)
    while True:
        removed = np.zeros(n, dtype=bool)
        removed[fainter[keep[brighter]]] = True
        if np.array_equal(~removed, keep):
            return keep
        keep = ~removed

__all__ = ["BadId", "Catalog", "cut_magnitude", "exact_ids", "kept_in_brightness_order",
           "merge_close_stars", "radec_to_vectors", "vectors_to_radec"]
