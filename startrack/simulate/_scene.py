"""What the camera sees at one attitude: star positions and magnitudes, no pixels yet."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera import Camera, stars_in_view
from startrack.sky import Catalog


@dataclass(frozen=True)
class Scene:
    """The stars in one frame, real ones first (catalog order, brightest first).

    ``mag`` is the instrument magnitude (catalog magnitude plus magnitude noise).
    False stars have ``catalog_id == catalog_row == -1``; a false star is either a hot
    pixel (one pixel, does not move with the camera) or a blob (a wide spot).
    """

    x: np.ndarray
    y: np.ndarray
    mag: np.ndarray
    catalog_id: np.ndarray
    catalog_row: np.ndarray
    is_false: np.ndarray
    hot_pixel: np.ndarray
    rotation: Rotation

    def __len__(self) -> int:
        return len(self.x)

    @property
    def n_real(self) -> int:
        return int(np.count_nonzero(~self.is_false))


def observe(catalog: Catalog, camera: Camera, rotation: Rotation, rng: np.random.Generator,
            *, missing: float = 0.0, false_stars: int = 0, mag_noise: float = 0.0,
            hot_pixel_fraction: float = 0.5,
            false_mag_range: tuple[float, float] | None = None,
            margin_px: float = 0.0) -> Scene:
    """The scene at ``rotation``: visible catalog stars, dropouts, noise and false stars.

    ``missing`` is the probability that each real star is dropped; ``false_stars`` spots
    are added uniformly over the image with magnitudes uniform in ``false_mag_range``
    (default: the range of the real stars in view). All randomness comes from ``rng``,
    drawn in a fixed order so one option never changes the others' draws.
    """
    if not 0.0 <= missing <= 1.0:
        raise ValueError(f"missing must be in [0, 1], got {missing}")
    if false_stars < 0 or mag_noise < 0 or not 0.0 <= hot_pixel_fraction <= 1.0:
        raise ValueError("false_stars and mag_noise must be >= 0, hot_pixel_fraction in [0, 1]")
    rows, x, y = stars_in_view(catalog, camera, rotation, margin_px)
    mags_in_view = catalog.mag[rows]

    kept = rng.random(len(rows)) >= missing
    noise = rng.standard_normal(len(rows)) * mag_noise
    rows, x, y = rows[kept], x[kept], y[kept]
    mag = mags_in_view[kept] + noise[kept]

    real = Scene(x=x, y=y, mag=mag, catalog_id=catalog.ids[rows].astype(np.int64),
                 catalog_row=rows.astype(np.int64), is_false=np.zeros(len(rows), dtype=bool),
                 hot_pixel=np.zeros(len(rows), dtype=bool), rotation=rotation)
    if false_mag_range is None:
        source = mags_in_view if len(mags_in_view) >= 2 else catalog.mag
        false_mag_range = (float(source.min()), float(source.max()))
    return add_false_stars(real, rng.random((int(false_stars), 4)), camera, false_mag_range,
                           hot_pixel_fraction, margin_px)


def add_false_stars(scene: Scene, uniforms: np.ndarray, camera: Camera,
                    mag_range: tuple[float, float], hot_pixel_fraction: float,
                    margin_px: float = 0.0) -> Scene:
    """``scene`` with one false star per row of ``uniforms`` (K x 4 numbers in [0, 1)):
    x and y uniform over the image (``margin_px`` from the edges), magnitude uniform in
    ``mag_range``, a hot pixel (a one-pixel spot) when the fourth is below
    ``hot_pixel_fraction``, else a star-like blob. Taking the uniforms rather than drawing
    them lets the bench nest its false stars across conditions (K=3 holds K=1's)."""
    u = np.asarray(uniforms, dtype=np.float64).reshape(-1, 4)
    k = len(u)
    lo = -0.5 + margin_px
    fx = lo + u[:, 0] * (camera.width - 2.0 * margin_px)
    fy = lo + u[:, 1] * (camera.height - 2.0 * margin_px)
    fmag = mag_range[0] + u[:, 2] * (mag_range[1] - mag_range[0])
    fhot = u[:, 3] < hot_pixel_fraction
    minus_one = np.full(k, -1, dtype=np.int64)
    return Scene(
        x=np.concatenate([scene.x, fx]),
        y=np.concatenate([scene.y, fy]),
        mag=np.concatenate([scene.mag, fmag]),
        catalog_id=np.concatenate([scene.catalog_id, minus_one]),
        catalog_row=np.concatenate([scene.catalog_row, minus_one]),
        is_false=np.concatenate([scene.is_false, np.ones(k, dtype=bool)]),
        hot_pixel=np.concatenate([scene.hot_pixel, fhot]),
        rotation=scene.rotation,
    )
