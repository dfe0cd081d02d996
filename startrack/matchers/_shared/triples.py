"""The orders in which matchers try star triples."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from functools import lru_cache

import numpy as np


def smart_triples(n: int) -> Iterator[tuple[int, int, int]]:
    """Star triples i < j < k in Mortari's Pyramid order (index gaps dj, dk outermost), which
    spreads the stars over the first tries so that a false star is soon left out."""
    for dj in range(1, n - 1):
        for dk in range(1, n - dj):
            for i in range(n - dj - dk):
                yield i, i + dj, i + dj + dk


@lru_cache(maxsize=64)
def triple_order(first: int, n: int, limit: int) -> tuple[tuple[int, int, int], ...]:
    """The triples tried, at most ``limit``: those of the ``first`` brightest stars in
    spreading order, then those that bring in the fainter stars up to ``n``."""
    triples = list(smart_triples(first))
    triples += [t for t in smart_triples(n) if t[2] >= first]
    return tuple(triples[:limit])


@lru_cache(maxsize=64)
def triple_array(first: int, n: int, limit: int) -> np.ndarray:
    """:func:`triple_order` as an (T x 3) int64 array, for the compiled kernels."""
    return np.array(triple_order(first, n, limit), dtype=np.int64).reshape(-1, 3)


def brightness_triples(n: int) -> list[tuple[int, int, int]]:
    """Every triple of the ``n`` brightest stars, those of the brightest stars first."""
    return sorted(itertools.combinations(range(n), 3), key=lambda t: (t[2], t[1], t[0]))

__all__ = [
    "brightness_triples", "smart_triples", "triple_array", "triple_order",
]
