"""The pinhole camera, camera files and the attitude conventions of interfaces.md."""

import dataclasses
import json
import math

import numpy as np
import pytest

from startrack.attitude import from_radec_roll, to_radec_roll
from startrack.camera._distortion import RadialDistortion
from startrack.camera._file import camera_from_dict, load_camera
from startrack.camera._model import Camera
from startrack.errors import InputError
from startrack.sky import radec_to_vectors


def test_pixel_vector_pixel_round_trip():
    cam = Camera.from_fov(1024, 768, 11.42, cx=500.25, cy=390.5)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-0.5, 1023.5, 200), rng.uniform(-0.5, 767.5, 200)
    v = cam.pixel_to_vector(x, y)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    x2, y2, front = cam.vector_to_pixel(v)
    assert front.all()
    np.testing.assert_allclose(x2, x, atol=1e-9)
    np.testing.assert_allclose(y2, y, atol=1e-9)


def test_fov_and_focal_length():
    cam = Camera.from_fov(1000, 500, 20.0)
    assert cam.f_px == pytest.approx(500.0 / math.tan(math.radians(10.0)))
    assert cam.fov_deg == pytest.approx(20.0)
    # The two image edges, half a pixel beyond the outer pixel centres, span the fov.
    left = cam.pixel_to_vector(np.array([-0.5]), np.array([cam.cy]))[0]
    right = cam.pixel_to_vector(np.array([999.5]), np.array([cam.cy]))[0]
    assert math.degrees(math.acos(left @ right)) == pytest.approx(20.0)
    optics = Camera.from_optics(4096, 4096, 100.0, 10.0)
    assert optics.f_px == pytest.approx(10000.0)


def test_principal_point_default_is_image_centre():
    cam = Camera.from_fov(640, 480, 10.0)
    assert (cam.cx, cam.cy) == (319.5, 239.5)
    v = cam.pixel_to_vector(np.array([319.5]), np.array([239.5]))[0]
    np.testing.assert_allclose(v, [0.0, 0.0, 1.0], atol=1e-15)


def test_camera_files_json_and_toml(tmp_path):
    j = tmp_path / "cam.json"
    j.write_text(json.dumps({"width": 800, "height": 600, "fov_deg": 12.0, "cx": 400.0}))
    t = tmp_path / "cam.toml"
    t.write_text("width = 800\nheight = 600\nfocal_length_mm = 50.0\npixel_size_um = 5.0\n")
    cj, ct = load_camera(j), load_camera(t)
    assert (cj.width, cj.height, cj.cx, cj.cy) == (800, 600, 400.0, 299.5)
    assert cj.fov_deg == pytest.approx(12.0)
    assert ct.f_px == pytest.approx(10000.0)


def test_unknown_or_missing_camera_key_is_input_error(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"width": 800, "height": 600, "fov_deg": 12.0, "fov": 3}))
    with pytest.raises(InputError, match="bad.json.*fov"):
        load_camera(bad)
    with pytest.raises(InputError, match="height"):
        camera_from_dict({"width": 10, "fov_deg": 5.0})
    with pytest.raises(InputError, match="nope.toml"):
        load_camera(tmp_path / "nope.toml")


@pytest.mark.parametrize("ra,dec,roll", [(0, 0, 0), (123.4, -56.7, 200.0), (300, 80, 359.5)])
def test_radec_roll_round_trip_and_boresight(ra, dec, roll):
    rot = from_radec_roll(ra, dec, roll)
    ra2, dec2, roll2 = to_radec_roll(rot)
    assert ra2 == pytest.approx(ra, abs=1e-9)
    assert dec2 == pytest.approx(dec, abs=1e-9)
    assert roll2 == pytest.approx(roll, abs=1e-9)
    np.testing.assert_allclose(rot.as_matrix() @ [0, 0, 1], radec_to_vectors(ra, dec),
                               atol=1e-12)


def _pixel_of(cam, rot, ra, dec):
    v_cam = rot.inv().apply(radec_to_vectors(ra, dec))
    x, y, front = cam.vector_to_pixel(v_cam)
    assert front
    return float(x), float(y)


def test_roll_zero_puts_north_up_and_east_left():
    cam = Camera.from_fov(1024, 1024, 10.0)
    ra, dec = 40.0, 20.0
    rot = from_radec_roll(ra, dec, 0.0)
    x_n, y_n = _pixel_of(cam, rot, ra, dec + 1.0)  # a star just north of the boresight
    assert y_n < cam.cy - 50 and abs(x_n - cam.cx) < 1e-6
    x_e, y_e = _pixel_of(cam, rot, ra + 1.0, dec)  # a star just east
    assert x_e < cam.cx - 50  # the sky seen from inside: east is to the left
    # Roll 90: up points east, so the eastern star is now above the centre.
    rot90 = from_radec_roll(ra, dec, 90.0)
    _, y_e90 = _pixel_of(cam, rot90, ra + 1.0, dec)
    assert y_e90 < cam.cy - 50


@pytest.mark.parametrize("ra,dec,roll", [(10, 20, 30), (250, -60, 300), (0, 89.999, 45),
                                         (180, -90, 10)])
def test_wcs_header_agrees_with_the_camera(ra, dec, roll):
    from astropy.wcs import WCS

    from startrack.outputs import wcs_header

    cam = Camera.from_fov(1024, 768, 11.42, cx=500.3, cy=390.1)
    rot = from_radec_roll(ra, dec, roll)
    wcs = WCS(wcs_header(cam, rot))
    x = np.array([0.0, 1023.0, 500.3, 100.0, 800.0])
    y = np.array([0.0, 767.0, 390.1, 600.0, 50.0])
    w_ra, w_dec = wcs.all_pix2world(x + 1.0, y + 1.0, 1)  # FITS pixels are 1-based
    want = rot.apply(cam.pixel_to_vector(x, y))
    got = radec_to_vectors(w_ra, w_dec)
    sep = np.degrees(np.arctan2(np.linalg.norm(np.cross(got, want), axis=1),
                                (got * want).sum(axis=1))) * 3600.0
    assert sep.max() < 0.1


@pytest.mark.parametrize("distortion", [None, RadialDistortion(k1=-0.05, k2=0.01)])
def test_with_focal_is_the_replaced_camera(distortion):
    cam = Camera.from_fov(1024, 768, 12.0, cx=500.25, cy=390.5, distortion=distortion)
    cam.optics, cam.half_diagonal_deg  # noqa: B018 (cached on cam: not to be carried over)
    for f in (2500.0, np.float64(4321.5)):
        fast, want = cam.with_focal(f), dataclasses.replace(cam, f_px=f)
        assert fast == want and type(fast.f_px) is type(f)
        assert fast.optics.geometry == want.optics.geometry
        assert fast.optics.geometry["f_px"] == f and fast.distortion is cam.distortion
        assert fast.half_diagonal_deg == want.half_diagonal_deg != cam.half_diagonal_deg
    assert cam.pinhole == dataclasses.replace(cam, distortion=None)
