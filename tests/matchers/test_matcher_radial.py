"""The radial matcher: shortlist diagnostics, too few neighbours for a feature, the
parameters, and the radial-features paper's camera (the contract every matcher meets is in
tests/matchers/test_matcher_contract.py)."""

import math

import numpy as np
import pytest
from synth import frames, prepared_matcher, synthetic_frame

from startrack.attitude import random_attitudes
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.match_records import MatchDiagnostics, Observation
from startrack.matchers import get_matcher
from startrack.sky import SkySpec, load_sky
from startrack.solver import identify

METHOD = "radial"


@pytest.fixture(scope="module")
def matcher(random_db):
    return prepared_matcher(METHOD, random_db)


def test_shortlists_are_reported(random_db, matcher):
    frame = next(frames(random_db.catalog, random_db.camera, 20, seed=1, min_stars=10))
    diag = identify(frame.obs, matcher).diagnostics
    assert diag.candidates > 0 and diag.extra["mean_shortlist"] > 0


def test_too_few_neighbours_for_a_feature(random_db, matcher):
    """Two or three stars give no star the ``min_rings`` neighbours a radial feature
    needs: no shortlist, so no hypothesis at all."""
    frame = next(frames(random_db.catalog, random_db.camera, 20, seed=3, min_stars=10))
    camera = frame.obs.camera
    for n in (2, 3):
        obs = Observation.from_pixels(frame.obs.x[:n], frame.obs.y[:n], camera, 0.05)
        assert list(matcher.hypotheses(obs, MatchDiagnostics())) == []


def test_parameters(random_db):
    db = random_db
    cls = get_matcher(METHOD)
    explicit = cls(db, radius_deg=6.0, ring_width_deg=0.05)
    assert math.isclose(explicit.radius_rad, math.radians(6.0))
    assert math.isclose(explicit.ring_width_rad, math.radians(0.05))
    assert cls(db, radius_deg=90.0).radius_rad == db.max_angle_rad
    # The default ring width follows the design noise.
    assert cls(db, noise_px=1.0).ring_width_rad > cls(db, noise_px=0.3).ring_width_rad
    with pytest.raises(ValueError):
        cls(db, frac=0.0)


def paper_camera() -> Camera:
    """The radial-features paper's camera: 4096 x 4096 pixels of 9 um, 4 x 4 deg."""
    f_mm = (4096 * 9e-3 / 2.0) / math.tan(math.radians(2.0))
    return Camera.from_optics(4096, 4096, f_mm, 9.0)


def test_paper_camera_geometry():
    camera = paper_camera()
    assert math.isclose(camera.fov_deg, 4.0, rel_tol=1e-9)
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=7.5))
    matcher = prepared_matcher(METHOD, StarDatabase(catalog, camera), frac=0.5)
    rng = np.random.default_rng(31)
    rotations = random_attitudes(20, rng)
    counts, solved, wrong = [], 0, 0
    for k in range(20):
        frame = synthetic_frame(catalog, camera, rotations[k], rng, noise_px=0.3)
        counts.append(len(frame.obs))
        sol = identify(frame.obs, matcher)
        if sol.solved:
            ok = np.array_equal(sol.cat_index, frame.truth_rows[sol.obs_index])
            solved, wrong = solved + ok, wrong + (not ok)
    assert 5 <= np.median(counts) <= 15  # about ten stars per frame, as in the paper
    assert wrong == 0
    # Frames with fewer than five stars cannot be verified (3 matched + 2 confirmed).
    assert solved >= 0.8 * sum(c >= 6 for c in counts)
