"""The compiled camera model (startrack._core.camera.optics) held to the numpy model it replaced
(tests/camera/camera_reference.py), to the last bit."""

import pickle

import numpy as np
import pytest
from camera_reference import (
    reference_distort,
    reference_half_diagonal_deg,
    reference_pixel_to_vector,
    reference_undistort,
    reference_vector_to_pixel,
)
from startrack._core.camera.optics import Optics, RadialLens

from startrack.camera._distortion import RadialDistortion
from startrack.camera._model import Camera

LENSES = [RadialDistortion(k1=-0.2), RadialDistortion(k1=0.1),
          RadialDistortion(k1=-0.05, k2=0.01, k3=-0.002), RadialDistortion(k1=0.3, k3=-2.0)]


def _lens(d: RadialDistortion) -> RadialLens:
    return RadialLens(d.k1, d.k2, d.k3, d.max_r2)


def test_undistort_and_distort_are_numpys_to_the_bit():
    rng = np.random.default_rng(5)
    for d in LENSES:
        u, v = rng.normal(0.0, 0.4, (2, 500))
        u[:3] = 0.0, np.nan, 5.0  # the centre, a NaN, one far beyond any fold
        v[:3] = 0.0, 0.1, 5.0
        got, want = _lens(d).undistort(u, v), reference_undistort(d, u, v)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        got, want = _lens(d).distort(u, v), reference_distort(d, u, v)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_the_camera_calls_the_compiled_model_in_any_shape():
    rng = np.random.default_rng(6)
    for d in [None, *LENSES[:3]]:
        cam = Camera.from_fov(1200, 800, 25.0, distortion=d)
        x, y = rng.uniform(-50, 1250, (2, 4, 60))
        np.testing.assert_array_equal(cam.pixel_to_vector(x, y),
                                      reference_pixel_to_vector(cam, x, y))
        vec = rng.normal(size=(7, 30, 3))
        vec[0, :5, 2] = 0.0  # behind or on the image plane
        for got, want in zip(cam.vector_to_pixel(vec), reference_vector_to_pixel(cam, vec),
                             strict=True):
            assert got.shape == want.shape == (7, 30)
            np.testing.assert_array_equal(got, want)
    assert Camera.from_fov(100, 100, 10.0).pixel_to_vector(3.0, 4.0).shape == (3,)


def test_optics_pickles_and_takes_empty_inputs():
    optics = Optics(500.0, 50.0, 40.0, 101, 81, RadialLens(-0.1, 0.0, 0.0, 10 / 3))
    again = pickle.loads(pickle.dumps(optics))
    x, y = np.array([0.0, 100.0]), np.array([80.0, 3.0])
    np.testing.assert_array_equal(again.pixel_to_vector(x, y), optics.pixel_to_vector(x, y))
    assert again.geometry["k1"] == -0.1 and again.geometry["max_r2"] == 10 / 3
    assert optics.pixel_to_vector(np.zeros(0), np.zeros(0)).shape == (0, 3)


def test_half_diagonal_is_as_it_was_to_the_bit():
    rng = np.random.default_rng(7)
    for d in [None, *LENSES]:
        for _ in range(50):
            width = int(rng.integers(50, 3000))
            height = int(width * rng.uniform(0.5, 1.5))
            cam = Camera.from_fov(width, height, rng.uniform(2.0, 30.0),
                                  cx=(width - 1) / 2 + rng.normal(0.0, 20.0),
                                  cy=(height - 1) / 2 + rng.normal(0.0, 20.0), distortion=d)
            corners = cam.pixel_to_vector(np.array([0.0, width - 1.0, 0.0, width - 1.0]),
                                          np.array([0.0, 0.0, height - 1.0, height - 1.0]))
            np.testing.assert_array_equal(cam.optics.corner_cosines(), corners[:, 2])
            assert cam.half_diagonal_deg == reference_half_diagonal_deg(cam)


def test_pixels_of_any_layout_or_type_are_taken_as_float64():
    cam = Camera.from_fov(1200, 800, 25.0, distortion=LENSES[0])
    grid = np.arange(40.0).reshape(5, 8) * 25.0
    for x in (grid[:, ::3], grid.T, grid.astype(np.float32), [0, 600, 1199]):
        want = reference_pixel_to_vector(cam, np.asarray(x, np.float64),
                                         np.asarray(x, np.float64)[::-1])
        got = cam.pixel_to_vector(x, np.asarray(x)[::-1])
        np.testing.assert_array_equal(got, want)
        assert got.flags.c_contiguous and got.shape == np.shape(x) + (3,)


def test_a_fits_halvings_cost_is_its_normal_equations_cost_to_the_bit():
    """A camera fit's halvings after the first evaluate the cost alone
    (startrack._core.camera.fit): it must be the number the full normal equations sum, to the
    bit, or a fit would step differently; and both are the squared pixel residuals
    (tests/solver/fov_fit_reference.py) to rounding."""
    from scipy.spatial.transform import Rotation
    from startrack._core.camera.fit import lsq_costs

    from tests.solver.fov_fit_reference import pixel_residuals

    rng = np.random.default_rng(17)
    for t, lens in enumerate([None, *LENSES[:3]] * 3):
        camera = Camera.from_fov(int(rng.integers(300, 3000)), int(rng.integers(300, 2000)),
                                 float(rng.choice([3.0, 20.0, 60.0])), distortion=lens)
        n = int(rng.integers(1, 60))
        x = rng.uniform(0, camera.width - 1, n)
        y = rng.uniform(0, camera.height - 1, n)
        rot = Rotation.random(random_state=t).as_matrix()
        # the catalog a little off the pixels' directions: residuals of a few pixels
        cat = rot @ camera.pixel_to_vector(x + rng.normal(0, 2, n), y).T
        cat = np.ascontiguousarray(cat.T)
        f = camera.f_px * float(rng.uniform(0.98, 1.02))
        k1 = 0.0 if lens is not None else float(rng.uniform(-0.2, 0.2))
        for n_params in (4, 5):
            full, alone = lsq_costs(camera.optics, x, y, cat, np.ascontiguousarray(rot), f,
                                    k1, n_params)
            assert full == alone
            want = np.sum(pixel_residuals(camera, rot, f, k1, x, y, cat) ** 2)
            assert full == pytest.approx(want, rel=1e-9) and full > 0.0


def test_the_focal_lengths_standard_error_is_numpys_least_squares_covariance():
    """The error a fit's stars leave on the focal length (startrack._core.camera.fit's
    focal_error, which the fitted rounds require to be a match radius at the corners)
    is sqrt((J^T J)^-1) of the joint least squares of the attitude and the focal length,
    J by central differences of the reference residuals, per pixel of noise; stars in a
    patch fix it far worse than stars across the frame, and a single star not at all."""
    from scipy.spatial.transform import Rotation
    from startrack._core.camera.fit import focal_error

    from startrack.attitude import wahba_matrices
    from tests.solver.fov_fit_reference import pixel_residuals

    rng = np.random.default_rng(23)
    errors = {}
    for t, lens in enumerate([None, LENSES[0], LENSES[2]]):
        camera = Camera.from_fov(1024, 768, 20.0, distortion=lens)
        for spread in (1.0, 0.05):  # across the frame, a patch
            n = 12
            x = 500 + spread * rng.uniform(-480, 480, n)
            y = 380 + spread * rng.uniform(-360, 360, n)
            rot = Rotation.random(random_state=t).as_matrix()
            cat = np.ascontiguousarray((rot @ camera.pixel_to_vector(x, y).T).T)
            start = wahba_matrices(camera.pixel_to_vector(x, y), cat)

            def residuals(p, camera=camera, x=x, y=y, cat=cat, start=start):
                turn = start @ Rotation.from_rotvec(p[:3]).as_matrix()
                return pixel_residuals(camera, turn, camera.f_px + p[3], 0.0, x, y, cat)

            steps = np.array([1e-7, 1e-7, 1e-7, 1e-4 * camera.f_px])
            jac = np.stack([(residuals(np.eye(4)[k] * h) - residuals(-np.eye(4)[k] * h))
                            / (2 * h) for k, h in enumerate(steps)], axis=1)
            want = np.sqrt(np.linalg.inv(jac.T @ jac)[3, 3]) / camera.f_px
            got = focal_error(camera.optics, x, y, cat)
            assert got == pytest.approx(want, rel=1e-4)
            errors[t, spread] = got
        assert errors[t, 0.05] > 10 * errors[t, 1.0]
        assert focal_error(camera.optics, x[:1], y[:1], cat[:1]) == np.inf
