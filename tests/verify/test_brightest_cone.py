"""The refit's brightest catalog stars in view, found through a cone lookup of the
catalog's held index (startrack.verify._refit.brightest_in_view): the very rows of the
scan over every star, which a narrow field cut deep passes almost whole before enough
stars fall in the image."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack._core.verify import camera_refit
from startrack.camera import Camera, RadialDistortion
from startrack.database import StarDatabase, held_cone_index
from startrack.sky import SkySpec, load_sky, random_sky
from startrack.verify._refit import CATALOG_STARS, brightest_in_view

CAMERA = Camera.from_fov(1024, 1024, 12.0)


@pytest.mark.parametrize("distorted", [False, True])
@pytest.mark.parametrize("n", [20, CATALOG_STARS])
def test_the_cones_rows_give_the_scans_rows(distorted, n):
    camera = CAMERA if not distorted else dataclasses.replace(
        CAMERA, distortion=RadialDistortion(k1=-0.2))
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=8.0), camera)
    cone = StarDatabase(catalog, camera).cone_index
    cos_limit = math.cos(math.radians(camera.half_diagonal_deg))
    for rotation in Rotation.random(30, random_state=np.random.default_rng(3)):
        matrix = np.ascontiguousarray(rotation.as_matrix())
        rows = cone.rows(matrix[:, 2], math.acos(cos_limit) * (1.0 + 1e-9) + 1e-12)
        assert len(rows) < len(catalog) / 50  # the cone: a sliver of the catalog
        every_row = camera_refit.brightest_in_view(camera.optics, catalog.vectors, matrix,
                                                   cos_limit, n)
        through_cone = camera_refit.brightest_in_view(camera.optics, catalog.vectors,
                                                      matrix, cos_limit, n, rows)
        np.testing.assert_array_equal(through_cone[0], every_row[0])
        np.testing.assert_array_equal(through_cone[1], every_row[1])


def test_a_narrow_field_cut_deep_looks_its_cone_up(monkeypatch):
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=8.0), CAMERA)
    cone = StarDatabase(catalog, CAMERA).cone_index
    scanned = []
    kernel = camera_refit.brightest_in_view
    monkeypatch.setattr(camera_refit, "brightest_in_view",
                        lambda *a: scanned.append(a[-1] is not None) or kernel(*a))
    for rotation in Rotation.random(10, random_state=np.random.default_rng(5)):
        matrix = rotation.as_matrix()
        np.testing.assert_array_equal(
            brightest_in_view(catalog.vectors, matrix, CAMERA, cone=cone)[0],
            brightest_in_view(catalog.vectors, matrix, CAMERA)[0])
    assert scanned == [True, False] * 10


def test_a_wide_field_on_a_deep_catalog_scans_every_row():
    # 40 deg on 200,000 stars: the cone would hold thousands, the scan stops at the 60th
    catalog = random_sky(200_000, seed=2)
    camera = Camera.from_fov(1024, 1024, 40.0)
    cone = StarDatabase(catalog, camera).cone_index
    matrix = Rotation.random(random_state=np.random.default_rng(4)).as_matrix()
    share = (1.0 - math.cos(math.radians(camera.half_diagonal_deg))) / 2.0
    assert len(catalog) * share * share > CATALOG_STARS
    np.testing.assert_array_equal(brightest_in_view(catalog.vectors, matrix, camera, cone=cone)[0],
                                  brightest_in_view(catalog.vectors, matrix, camera)[0])


def test_a_candidate_out_of_range_is_refused():
    catalog = random_sky(100, seed=1)
    with pytest.raises(IndexError, match="candidate row 100"):
        camera_refit.brightest_in_view(CAMERA.optics, catalog.vectors, np.eye(3), 0.9, 10,
                                       np.array([3, 100], np.int64))


def test_the_catalog_holds_one_cone_index_and_pickles_without_it():
    catalog = random_sky(2000, seed=6)
    assert held_cone_index(catalog) is None  # none built: none made for the refit
    first = StarDatabase(catalog, CAMERA).cone_index
    assert held_cone_index(catalog) is first
    assert StarDatabase(catalog, Camera.from_fov(640, 480, 30.0)).cone_index is first
    copy = pickle.loads(pickle.dumps(catalog))
    assert held_cone_index(copy) is None
    np.testing.assert_array_equal(copy.vectors, catalog.vectors)
