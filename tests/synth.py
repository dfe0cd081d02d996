"""Synthetic observations for matcher tests: exact or noisy centroids of a known attitude."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.matchers.base import Observation
from startrack.scene import stars_in_view
from startrack.sky import Catalog


@dataclass(frozen=True)
class SyntheticFrame:
    obs: Observation
    truth_rows: np.ndarray  # catalog row of each observed star, -1 for a false star
    rotation: Rotation


def synthetic_frame(catalog: Catalog, camera: Camera, rotation: Rotation,
                    rng: np.random.Generator, *, noise_px: float = 0.0, false_stars: int = 0,
                    missing: float = 0.0, sigma_px: float | None = None) -> SyntheticFrame:
    """Centroids of the catalog stars in view (brightest first), perturbed by Gaussian
    noise, with stars dropped and false stars inserted at random brightness ranks."""
    rows, x, y = stars_in_view(catalog, camera, rotation)
    keep = rng.random(len(rows)) >= missing
    rows, x, y = rows[keep], x[keep], y[keep]
    x = x + rng.normal(0.0, noise_px, len(x)) if noise_px > 0 else x
    y = y + rng.normal(0.0, noise_px, len(y)) if noise_px > 0 else y
    truth = rows.astype(np.int64)
    for _ in range(false_stars):
        pos = int(rng.integers(0, len(truth) + 1))
        x = np.insert(x, pos, rng.uniform(0, camera.width - 1))
        y = np.insert(y, pos, rng.uniform(0, camera.height - 1))
        truth = np.insert(truth, pos, -1)
    sigma = noise_px if sigma_px is None else sigma_px
    obs = Observation.from_pixels(x, y, camera, max(sigma, 0.05))
    return SyntheticFrame(obs, truth, rotation)
