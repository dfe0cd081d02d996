"""Lens distortion: the interfaces.md formula, its inverse, camera files and TAN-SIP."""

import csv
import json
import math

import numpy as np
import pytest

from startrack.camera._distortion import RadialDistortion
from startrack.camera._file import camera_from_dict, load_camera
from startrack.camera._model import Camera
from startrack.errors import InputError


def _grid(cam: Camera, n: int = 41):
    x, y = np.meshgrid(np.linspace(-0.5, cam.width - 0.5, n),
                       np.linspace(-0.5, cam.height - 0.5, n))
    return x.ravel(), y.ravel()


def test_projection_follows_the_interfaces_formula():
    dist = RadialDistortion(k1=-0.3, k2=0.05, k3=-0.01)
    cam = Camera.from_fov(1024, 1024, 20.0, distortion=dist)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-0.2, 0.2, (2, 200))
    x, y, front = cam.vector_to_pixel(np.column_stack([u, v, np.ones_like(u)]) * 2.0)
    r2 = u * u + v * v
    s = 1 + dist.k1 * r2 + dist.k2 * r2**2 + dist.k3 * r2**3
    assert front.all()
    np.testing.assert_allclose(x, cam.cx + cam.f_px * u * s, atol=1e-9)
    np.testing.assert_allclose(y, cam.cy + cam.f_px * v * s, atol=1e-9)


def test_inverse_round_trips_and_k1_moves_the_corners():
    cam = Camera.from_fov(1024, 1024, 20.0, distortion=RadialDistortion(k1=-0.3))
    x, y = _grid(cam)
    x2, y2, front = cam.vector_to_pixel(cam.pixel_to_vector(x, y))
    assert front.all()
    assert np.abs(x2 - x).max() < 1e-9 and np.abs(y2 - y).max() < 1e-9
    xp, yp, _ = cam.pinhole.vector_to_pixel(cam.pixel_to_vector(x, y))
    shift = np.hypot(xp - x, yp - y)
    assert shift[len(shift) // 2] < 1e-9  # the principal point does not move
    assert 10.0 < shift.max() < 16.0  # "about 10 px at the corners" (14 px exactly)


def test_beyond_the_fold_is_not_projected():
    cam = Camera.from_fov(1024, 1024, 20.0, distortion=RadialDistortion(k1=-0.3))
    # 60 degrees off-axis: past r^2 = 1/(3 * 0.3), where r(1 + k1 r^2) turns back inwards.
    far = np.array([[math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))]])
    _, _, front = cam.vector_to_pixel(far)
    assert not front[0]


@pytest.mark.parametrize("k", [(-0.3, 0.0, 0.0), (-0.02, 0.0, 0.0), (0.2, 0.0, 0.0),
                               (-0.3, 0.05, -0.01), (0.1, -0.05, 0.001), (0.0, 0.0, 0.0)])
def test_the_fold_radius_is_where_the_observed_radius_stops_growing(k):
    """max_r2 (a k1-only lens's in closed form, others' from the cubic): the observed
    radius r (1 + k1 r^2 + ...) grows up to it and falls just past it; inf if never."""
    dist = RadialDistortion(*k)
    r2 = dist.max_r2
    assert r2 is dist.max_r2  # computed once per model
    if not math.isfinite(r2):
        s = np.linspace(0.0, 100.0, 100001)
        assert np.all(np.diff(np.sqrt(s) * dist.factor(s)) > 0)
        return
    slope = 1.0 + r2 * (3.0 * k[0] + r2 * (5.0 * k[1] + r2 * 7.0 * k[2]))
    assert abs(slope) < 1e-12
    below, above = np.sqrt(r2) * np.array([0.999, 1.0, 1.001])[[0, 2]]
    rd = np.array([below, math.sqrt(r2), above]) * dist.factor(
        np.array([below, math.sqrt(r2), above]) ** 2)
    assert rd[0] < rd[1] and rd[2] < rd[1]


def test_a_lens_that_folds_inside_the_image_is_refused():
    with pytest.raises(InputError, match="folds back"):
        Camera.from_fov(1024, 1024, 90.0, distortion=RadialDistortion(k1=-1.0))


def test_camera_file_distortion_round_trip(tmp_path):
    data = {"width": 1024, "height": 768, "fov_deg": 11.42,
            "distortion": {"model": "radial", "k1": -0.1, "k2": 0.02, "k3": 0.0}}
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(data))
    cam = load_camera(path)
    assert cam.distortion == RadialDistortion(-0.1, 0.02, 0.0)
    again = camera_from_dict(cam.to_dict())
    assert again == cam
    assert camera_from_dict({"width": 10, "height": 10, "fov_deg": 5.0,
                             "distortion": {"model": "radial", "k1": 0.0}}).distortion is None


@pytest.mark.parametrize("bad, message", [
    ({"model": "fisheye", "k1": 0.1}, "model"),
    ({"k1": 0.1}, "model"),
    ({"model": "radial", "k4": 0.1}, "unknown distortion key"),
    ({"model": "radial", "k1": "big"}, "must be a number"),
    ({"model": "radial", "k1": True}, "must be a number"),
    ({"model": "radial", "k1": float("nan")}, "finite"),
    ([0.1], "must be a table"),
])
def test_bad_distortion_entries_are_input_errors(bad, message):
    with pytest.raises(InputError, match=message):
        camera_from_dict({"width": 100, "height": 100, "fov_deg": 10.0, "distortion": bad},
                         where="cam.json")


def test_simulate_renders_the_lens_and_identify_solves_with_its_model(tmp_path):
    import subprocess
    import sys

    from startrack.attitude import boresight_error_arcsec, from_radec_roll

    lens = tmp_path / "lens.json"
    lens.write_text(json.dumps({"width": 1024, "height": 1024, "fov_deg": 20.0,
                                "distortion": {"model": "radial", "k1": -0.3}}))
    sim = subprocess.run([sys.executable, "-m", "startrack", "simulate", "--frames", "1",
                          "--camera", str(lens), "--attitude", "80,20,10", "--sky",
                          "hipparcos", "--out", str(tmp_path / "sim")], capture_output=True,
                         text=True)
    assert sim.returncode == 0, sim.stderr
    tmp_path = tmp_path / "sim"
    side = json.loads((tmp_path / "frame_0000.json").read_text())
    assert side["camera"]["distortion"]["k1"] == -0.3
    stars = list(csv.DictReader((tmp_path / "stars.csv").open()))
    cam = camera_from_dict(side["camera"])
    # The rendered positions are the distorted ones (a pinhole would put them elsewhere).
    from startrack.sky import SkySpec, load_sky

    catalog = load_sky(SkySpec.from_dict(side["sky"]), cam)
    rot = from_radec_roll(80, 20, 10)
    ids = {int(r["catalog_id"]): (float(r["x"]), float(r["y"])) for r in stars}
    rows = [k for k, hip in enumerate(catalog.ids) if int(hip) in ids]
    x, y, _ = cam.vector_to_pixel(rot.inv().apply(catalog.vectors[rows]))
    got = np.array([ids[int(catalog.ids[k])] for k in rows])
    assert np.abs(got - np.column_stack([x, y])).max() < 1e-6
    run = subprocess.run([sys.executable, "-m", "startrack", "identify",
                          str(tmp_path / "frame_0000.png"), "--format", "json"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    att = json.loads(run.stdout)["attitude"]
    err = boresight_error_arcsec(from_radec_roll(att["ra_deg"], att["dec_deg"], 0.0),
                                 from_radec_roll(80, 20, 0.0))
    assert err < 10.0
