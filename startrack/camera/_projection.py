"""Which catalog stars a camera at an attitude sees, and where they land in its pixels."""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera._model import Camera

__all__ = ["StarVectors", "stars_in_view"]


class StarVectors(Protocol):
    """A star list with a unit vector per star (a catalog, in ICRS)."""

    vectors: np.ndarray


def stars_in_view(catalog: StarVectors, camera: Camera, rotation: Rotation,
                  margin_px: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Catalog rows of the stars that land in the image, with their pixel (x, y)."""
    boresight = rotation.apply([0.0, 0.0, 1.0])
    # Cone pre-filter: a cheap dot product discards almost the whole sky before projecting.
    cos_cone = math.cos(math.radians(min(camera.half_diagonal_deg + 0.1, 179.0)))
    rows = np.flatnonzero(catalog.vectors @ boresight > cos_cone)
    v_cam = rotation.inv().apply(catalog.vectors[rows]).reshape(-1, 3)
    x, y, front = camera.vector_to_pixel(v_cam)
    keep = front & camera.in_image(x, y, margin_px)
    return rows[keep], x[keep], y[keep]
