"""Deterministic bench frames: frame i of a run is the same sky patch in every condition.

Every random draw comes from a stream seeded by (seed, frame, purpose) only, and draws
are made so that a condition's value scales or thresholds them rather than changing
them: standard normals scaled by the noise level, uniforms compared with the dropout
fraction, a fixed sequence of false stars of which the first K are used. Conditions are
then paired comparisons: the only difference between two conditions' frame i is the
perturbation itself, and every method sees exactly the same frames.

A condition may also make the camera wrong: the frames are seen through
:func:`true_camera` (the run's camera with the condition's lens distortion) and the
matcher is told :func:`matcher_camera` (the FOV off by ``fov_error``, only the modelled
part of the distortion).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from startrack.attitude import random_attitudes
from startrack.bench._conditions import SOURCES, Condition
from startrack.camera import Camera, RadialDistortion, stars_in_view
from startrack.centroids import DEFAULT_SIGMA_PX
from startrack.match_records import Observation
from startrack.simulate import (
    REFERENCE_BV,
    Effects,
    Scene,
    SensorModel,
    add_false_stars,
    observe,
)
from startrack.sky import Catalog

# Stream purposes: changing one never changes another's draws.
_ATTITUDE, _SCENE, _FALSE, _NOISE, _PIXELS, _EFFECTS = range(6)
# The sigma the matcher is told for exact centroids (a zero tolerance would be unusable).
SIGMA_FLOOR_PX = 0.05
# An extracted centroid this close to a scene star is that star (for scoring only).
TRUTH_RADIUS_PX = 2.0
#: how a false star's magnitude is drawn (see :func:`frame_scene`)
FALSE_MAGS = ("uniform", "faint")


@dataclass(frozen=True)
class BenchFrame:
    """One frame as a matcher sees it, with the truth needed to score the answer.

    ``truth_rows[k]`` is the catalog row of observed star k, or -1 for a false star (or a
    spot not matched to any scene star). ``n_in_view``: catalog stars in the image before
    dropout. ``centroid_ms``: time to extract the centroids (images only, else 0).
    """

    obs: Observation
    truth_rows: np.ndarray
    rotation: Rotation
    n_in_view: int
    centroid_ms: float = 0.0


def true_camera(camera: Camera, condition: Condition) -> Camera:
    """The camera the frames of ``condition`` are seen through."""
    k1 = condition.distortion_k1 + condition.modelled_k1
    return camera.with_distortion(RadialDistortion(k1=k1)) if k1 else camera


def matcher_camera(camera: Camera, condition: Condition) -> Camera:
    """The camera the matcher is told about under ``condition``."""
    distortion = camera.distortion
    if condition.distortion_k1 or condition.modelled_k1:
        distortion = RadialDistortion(k1=condition.modelled_k1)
    f_px = camera.f_px
    if condition.fov_error:
        f_px = Camera.from_fov(camera.width, camera.height,
                               camera.fov_deg * (1.0 + condition.fov_error)).f_px
    return dataclasses.replace(camera, f_px=f_px, distortion=None).with_distortion(distortion)


def _rng(seed: int, index: int, purpose: int) -> np.random.Generator:
    return np.random.default_rng([seed, index, purpose])


def frame_attitude(seed: int, index: int) -> Rotation:
    """Frame ``index``'s attitude: uniform over SO(3), from (seed, index) alone."""
    return random_attitudes(1, _rng(seed, index, _ATTITUDE))[0]


def frame_scene(catalog: Catalog, camera: Camera, condition: Condition, seed: int,
                index: int, hot_pixel_fraction: float = 0.5,
                false_mags: str = "uniform") -> tuple[Scene, np.ndarray]:
    """The scene of frame ``index`` under ``condition`` (no position noise yet), and the
    catalog rows in view before dropout (ascending, i.e. brightest first).

    ``false_mags`` (:data:`FALSE_MAGS`): a false star's magnitude is uniform between the
    brightest and the faintest star in view ("uniform"), or between the fifth brightest
    real star observed and the faintest ("faint": the five brightest spots stay real)."""
    rotation = frame_attitude(seed, index)
    rows_in_view, _, _ = stars_in_view(catalog, camera, rotation)
    # observe() thresholds one uniform per star in view and scales one normal per star,
    # so dropouts and magnitude noise are nested across conditions.
    real = observe(catalog, camera, rotation, _rng(seed, index, _SCENE),
                   missing=condition.missing, false_stars=0, mag_noise=condition.mag_noise)
    # False stars: a fixed per-frame sequence (x, y, mag, hot) of which the first K are
    # used, so K=3 contains K=1's star (observe() draws each attribute as a block of K).
    u = _rng(seed, index, _FALSE).random((int(condition.false_stars), 4))
    mags = catalog.mag[rows_in_view] if len(rows_in_view) >= 2 else catalog.mag
    low, high = float(mags.min()), float(mags.max())
    if false_mags == "faint" and len(real.mag):
        low = float(np.sort(real.mag)[min(4, len(real.mag) - 1)])
        high = max(high, low)
    elif false_mags not in FALSE_MAGS:
        raise ValueError(f"false_mags must be one of {FALSE_MAGS}, got {false_mags!r}")
    scene = add_false_stars(real, u, camera, (low, high), hot_pixel_fraction)
    return scene, rows_in_view


def frame_effects(effects: Effects | None, condition: Condition) -> Effects:
    """The run's effects (its config's tables) at ``condition``'s effect levels."""
    return (effects or Effects()).with_levels(
        cosmic_rays=condition.cosmic_rays, stray_light=condition.stray_light,
        temperature_c=condition.temperature_c)


def frame_colours(scene: Scene, condition: Condition) -> np.ndarray | None:
    """The B-V of each scene star under ``condition``: its colour level for every real star
    (NaN, a Sun-like star, for false stars), or None at the base level (as before the
    axis existed: no colour)."""
    if condition.colour_index == REFERENCE_BV:
        return None
    return np.where(scene.is_false, np.nan, float(condition.colour_index))


def make_frame(catalog: Catalog, camera: Camera, condition: Condition, seed: int,
               index: int, *, source: str = "centroids", sensor: SensorModel | None = None,
               hot_pixel_fraction: float = 0.5, effects: Effects | None = None,
               false_mags: str = "uniform") -> BenchFrame:
    """Frame ``index`` of a run under ``condition``, as observed stars brightest first.

    ``source="centroids"``: the true positions plus Gaussian noise of ``noise_px``.
    ``source="images"``: the frame is rendered with ``sensor`` and the centroids are
    extracted from the pixels (the noise then comes from the sensor; ``noise_px`` is
    ignored), with ``effects`` at the condition's levels (:func:`frame_effects`; their
    randomness has its own stream, so the pixel noise is the same at every level) and
    every star of the condition's colour (:func:`frame_colours`). The observation carries
    :func:`matcher_camera`.
    """
    seen = true_camera(camera, condition)
    scene, rows_in_view = frame_scene(catalog, seen, condition, seed, index,
                                      hot_pixel_fraction, false_mags)
    told = matcher_camera(camera, condition)
    if source == "centroids":
        return _from_centroids(scene, rows_in_view, told, condition, seed, index)
    if source == "images":
        return _from_image(scene, rows_in_view, seen, told, sensor or SensorModel(), seed,
                           index, frame_effects(effects, condition),
                           frame_colours(scene, condition))
    raise ValueError(f"source must be one of {SOURCES}, got {source!r}")


def _from_centroids(scene: Scene, rows_in_view: np.ndarray, camera: Camera,
                    condition: Condition, seed: int, index: int) -> BenchFrame:
    # One pair of normals per star in view, drawn before dropout and indexed by star, so
    # a star's error is the same in every condition up to the noise scale.
    normals = _rng(seed, index, _NOISE).standard_normal((len(rows_in_view), 2))
    real = ~scene.is_false
    where = np.searchsorted(rows_in_view, scene.catalog_row[real])
    x, y = scene.x.copy(), scene.y.copy()
    x[real] += condition.noise_px * normals[where, 0]
    y[real] += condition.noise_px * normals[where, 1]
    order = np.argsort(scene.mag, kind="stable")
    sigma = max(condition.noise_px, SIGMA_FLOOR_PX)
    flux = 10.0 ** (-0.4 * scene.mag[order])
    obs = Observation.from_pixels(x[order], y[order], camera, sigma, flux)
    return BenchFrame(obs, scene.catalog_row[order], scene.rotation, len(rows_in_view))


def _from_image(scene: Scene, rows_in_view: np.ndarray, camera: Camera, told: Camera,
                sensor: SensorModel, seed: int, index: int,
                effects: Effects | None = None, bv: np.ndarray | None = None) -> BenchFrame:
    from startrack.centroids import extract_centroids
    from startrack.simulate import render_frame

    image = render_frame(scene, camera, sensor, _rng(seed, index, _PIXELS), effects=effects,
                         effects_rng=_rng(seed, index, _EFFECTS), bv=bv)
    t0 = time.perf_counter()
    found = extract_centroids(image)
    centroid_ms = (time.perf_counter() - t0) * 1000.0
    truth = label_spots(found.x, found.y, scene.x, scene.y, scene.catalog_row)
    obs = Observation.from_pixels(found.x, found.y, told, DEFAULT_SIGMA_PX, found.flux)
    return BenchFrame(obs, truth, scene.rotation, len(rows_in_view), centroid_ms)


def label_spots(x: np.ndarray, y: np.ndarray, star_x: np.ndarray, star_y: np.ndarray,
                star_rows: np.ndarray) -> np.ndarray:
    """The catalog row of each spot (x, y): that of the drawn star within
    :data:`TRUTH_RADIUS_PX` (``star_rows``, -1 for a false star), else -1. For scoring
    extracted centroids against the scene they were rendered from."""
    truth = np.full(len(x), -1, dtype=np.int64)
    if len(x) and len(star_x):
        dist, nearest = cKDTree(np.column_stack([star_x, star_y])).query(
            np.column_stack([x, y]), distance_upper_bound=TRUTH_RADIUS_PX)
        hit = np.isfinite(dist)
        truth[hit] = np.asarray(star_rows, dtype=np.int64)[nearest[hit]]
    return truth

__all__ = [
    "BenchFrame", "FALSE_MAGS", "SIGMA_FLOOR_PX", "TRUTH_RADIUS_PX", "frame_attitude",
    "frame_colours", "frame_effects", "frame_scene", "label_spots", "make_frame", "matcher_camera",
    "true_camera",
]
