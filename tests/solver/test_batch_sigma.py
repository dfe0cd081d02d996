"""A batch whose inputs differ in centroid error (an image's is continuous: the size of
its star images) holds one identifier per camera, sky and method and one blind search per
sky and range, each told the input's error, not one per value (each reloaded its tables,
and a long batch grew without bound)."""

from __future__ import annotations

import numpy as np

from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.centroids import Centroids, frame_sigma_px
from startrack.sky import SkySpec, load_sky
from startrack.solver._pipeline import FrameInput, Options, Pipeline

CAMERA = Camera.from_fov(1024, 1024, 20.0)
AREAS = (4, 30, 60, 120)  # star images of growing area: growing centroid errors


def _frames(seed: int):
    """Seeded frames of the random sky, each with star images of its own area."""
    catalog = load_sky(SkySpec(kind="random"))
    rng = np.random.default_rng(seed)
    out = []
    for k, rot in enumerate(random_attitudes(len(AREAS), rng)):
        _, x, y = stars_in_view(catalog, CAMERA, rot)
        x, y = x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))
        flux = np.arange(len(x), 0, -1, dtype=float)
        area = np.full(len(x), AREAS[k], np.int64)
        out.append(FrameInput(f"f{k}", Centroids(x, y, flux, area=area)))
    return out


def _solve_all(pipeline: Pipeline, frames):
    results = [pipeline.solve(frame) for frame in frames]
    sigmas = [r.sigma_px for r in results]
    assert sigmas == [frame_sigma_px(f.centroids) for f in frames]
    assert len(set(sigmas)) >= 3  # the inputs do differ in centroid error
    return results


def test_a_given_fov_batch_holds_one_identifier_whatever_the_centroid_error():
    pipeline = Pipeline(Options(fov_deg=20.0, size=(1024, 1024), sky="random",
                                fov_tolerance=0.0))
    results = _solve_all(pipeline, _frames(3))
    assert all(r.solution.solved for r in results)
    assert len(pipeline._identifiers) == 1
    # each answer was matched with its own error: the record's radius grows with it
    radii = [r.match_radius_px for r in results]
    assert radii == sorted(radii) and radii[0] < radii[-1]


def test_a_blind_batch_holds_one_search_per_sky_and_range():
    pipeline = Pipeline(Options(size=(1024, 1024), sky="random"))
    results = _solve_all(pipeline, _frames(4))
    assert sum(r.solution.solved for r in results) >= 3
    assert len(pipeline._blind) == 1
    (solver,) = pipeline._blind.values()
    assert solver.sigma_px == results[-1].sigma_px  # the last input's error, set on it
