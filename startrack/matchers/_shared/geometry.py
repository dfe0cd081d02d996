"""Small vector geometry the matchers share: triple products, handedness, angle tables."""

from __future__ import annotations

import numpy as np

from startrack._core.matchers.geometry import angle_table as _angles


def triple_products(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """a . (b x c) over the last axis: positive for a counter-clockwise triangle seen from
    outside the sphere. A rotation keeps its sign, a reflection flips it."""
    a, b, c = (np.asarray(v, dtype=np.float64) for v in (a, b, c))
    return (a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
            + a[..., 1] * (b[..., 2] * c[..., 0] - b[..., 0] * c[..., 2])
            + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0]))


def handedness(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The sign (-1, 0, +1) of the triple product of each triangle (a, b, c)."""
    return np.sign(triple_products(a, b, c))


def angle_table(a: np.ndarray, b: np.ndarray | None = None) -> np.ndarray:
    """Angles (radians) between the rows of ``a`` and of ``b`` (default ``a``)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = a if b is None else np.ascontiguousarray(b, dtype=np.float64)
    return _angles(a, b)

__all__ = [
    "angle_table", "handedness", "triple_products",
]
