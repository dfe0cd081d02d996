"""A check of a frame's brightest spots alone counts only the brightest catalog stars in
the image (``VerifyConfig.catalog_stars``): a deep catalog's faint stars, which such spots
cannot confirm, no longer raise the chance of a coincidence the bound allows for, so a
right answer a deep sky refused passes; wrong hypotheses stay refused."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.sky import random_sky
from startrack.verify._verification import VerifyConfig, verify

CAMERA = Camera.from_fov(1024, 1024, 17.5)
SPOTS, FALSE, CAP = 16, 4, 32
#: a wide match radius (2.5 px centroids, blown-up stars): a deep catalog's stars then
#: cover enough of the image that 8 confirmed spots of 12 could be a coincidence
CONFIG = VerifyConfig(min_radius_px=10.0)


@pytest.fixture(scope="module")
def deep_db() -> StarDatabase:
    return StarDatabase(random_sky(30000, seed=5), CAMERA)  # about 220 stars in view


def _bright_frame(db: StarDatabase, seed: int):
    """The 16 brightest stars in view of a random attitude, FALSE of them (past the
    first four) moved to random places: (observation, the first four's catalog rows)."""
    rng = np.random.default_rng(seed)
    rotation = random_attitudes(1, rng)[0]
    rows, x, y = stars_in_view(db.catalog, CAMERA, rotation)
    order = np.argsort(db.catalog.mag[rows], kind="stable")[:SPOTS]
    rows, x, y = rows[order], x[order].copy(), y[order].copy()
    moved = rng.choice(np.arange(4, SPOTS), FALSE, replace=False)
    x[moved], y[moved] = rng.uniform(0, 1023, (2, FALSE))
    return Observation.from_pixels(x, y, CAMERA, 0.5), rows[:4]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_brightest_spots_pass_against_the_brightest_catalog_stars(deep_db, seed):
    obs, rows = _bright_frame(deep_db, seed)
    hyp = Hypothesis(np.arange(4), rows)
    every = verify(hyp, obs, deep_db, CONFIG)
    brightest = verify(hyp, obs, deep_db, replace(CONFIG, catalog_stars=CAP))
    # the same spots confirmed, the chance of it far smaller: a refusal becomes an answer
    assert brightest.confirmed >= SPOTS - 4 - FALSE
    assert brightest.false_probability < every.false_probability / 10.0
    assert not every.accepted and brightest.accepted


def test_wrong_hypotheses_stay_refused_against_the_brightest_catalog_stars(deep_db):
    rng = np.random.default_rng(7)
    config = replace(CONFIG, catalog_stars=CAP)
    bright = np.arange(2000)  # catalog rows are brightest first
    for seed in range(40):
        obs, _ = _bright_frame(deep_db, 100 + seed)
        hyp = Hypothesis(np.arange(4), rng.choice(bright, 4, replace=False))
        assert not verify(hyp, obs, deep_db, config).accepted
