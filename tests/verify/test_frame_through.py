"""A Frame made in C from the camera's optics (``frame_through``, what FrameVerifier, the
fitted rounds and tracking use) checks hypotheses exactly as one made from the camera's
fields as a dict (``Frame(..., geometry)``), pinhole and distorted alike."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from startrack._core.verify.entry_points import Frame, Verifier, frame_through

from startrack.attitude import random_attitudes
from startrack.camera import Camera, RadialDistortion, stars_in_view
from startrack.database import StarDatabase
from startrack.match_records import Observation
from startrack.sky import random_sky
from startrack.verify._frame import FrameVerifier, camera_geometry
from startrack.verify._verification import VerifyConfig

PINHOLE = Camera.from_fov(1024, 1024, 17.5)


@pytest.mark.parametrize("k1", [0.0, -0.15])
def test_a_frame_through_the_optics_checks_as_the_dict_made_one(k1):
    camera = PINHOLE if k1 == 0.0 else dataclasses.replace(
        PINHOLE, distortion=RadialDistortion(k1=k1))
    db = StarDatabase(random_sky(3000, seed=4), camera)
    rng = np.random.default_rng(9)
    checked = accepted = 0
    for rotation in random_attitudes(6, rng):
        rows, x, y = stars_in_view(db.catalog, camera, rotation)
        if len(rows) < 8:
            continue
        x, y = x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))
        obs = Observation.from_pixels(x, y, camera, 0.5, np.arange(len(x), 0, -1.0))
        ours = FrameVerifier(obs, db, VerifyConfig())
        made = Frame(*(np.ascontiguousarray(a, np.float64) for a in (obs.vectors, obs.x, obs.y)),
                     obs.kernel_flux(), camera_geometry(camera))
        theirs = Verifier(made, ours.params, db.cone_index.table,
                          np.ascontiguousarray(db.catalog.mag), None)
        right = np.arange(4, dtype=np.int64), np.asarray(rows[:4], np.int64)
        wrong = right[0], np.asarray(rng.choice(len(db.catalog), 4, replace=False), np.int64)
        for hyp in (right, wrong):
            a, b = ours.check(*hyp), theirs.check(*hyp)
            assert a.status == b.status and a.confirmed == b.confirmed
            np.testing.assert_array_equal(a.obs, b.obs)
            np.testing.assert_array_equal(a.rows, b.rows)
            np.testing.assert_array_equal(a.final, b.final)
            if a.residuals is not None:
                np.testing.assert_array_equal(a.residuals, b.residuals)
                accepted += 1
            checked += 1
    assert checked >= 8 and accepted >= 3


def test_a_frame_through_refuses_arrays_of_unequal_lengths():
    v = np.zeros((3, 3))
    with pytest.raises(ValueError, match="unequal lengths"):
        frame_through(PINHOLE.optics, v, np.zeros(3), np.zeros(2), np.zeros(3))
