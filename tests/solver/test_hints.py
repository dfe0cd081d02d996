"""Hints: a pointing cone and a scale range narrow the search and never loosen it; a FITS
header's WCS and time are hints by default; --downsample; --config for identify."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from astropy.coordinates import SkyCoord
from astropy.io import fits
from astropy.wcs import WCS
from repo_paths import DATA

import startrack
from startrack.attitude import from_radec_roll
from startrack.camera import Camera, stars_in_view
from startrack.errors import InputError
from startrack.io import read_image
from startrack.sky import random_sky
from startrack.solver._hints import (
    Hints,
    Pointing,
    Scale,
    cone_radius_deg,
    cut_to_cone,
    fov_range_deg,
    header_hints,
    header_time,
)

FRAME = DATA / "realsky_azi45.png"
AZI45 = (355.2046, 58.1518)  # tests/data/README.md
HINT = dict(ra=355.0, dec=58.0, radius=2.0, scale_low=10.0, scale_high=13.0)


def _close(result, ra_dec, arcsec=30.0) -> bool:
    ra, dec = ra_dec
    return (abs(result.ra_deg - ra) * math.cos(math.radians(dec)) < arcsec / 3600
            and abs(result.dec_deg - dec) < arcsec / 3600)


def test_scale_units_are_solve_fields():
    width = 1024
    assert Scale(10, 13).fov_deg(10, width) == 10
    # 40.1 arcsec per pixel over 1024 px: a pinhole's 2 atan(512 * scale)
    fov = Scale(40, 41, "arcsecperpix").fov_deg(40.1, width)
    assert fov == pytest.approx(math.degrees(2 * math.atan(512 * math.radians(40.1 / 3600))))
    # 35 mm lens, 6.9 um pixels (the real frames' camera): 11.53 deg (11.42 measured)
    assert Scale(35, 35, "focalmm", 6.9).fov_deg(35, width) == pytest.approx(
        math.degrees(2 * math.atan(512 * 6.9e-3 / 35)))
    nominal, tol = fov_range_deg(Scale(10, 13), width)
    assert nominal * (1 - tol) == pytest.approx(10) and nominal * (1 + tol) == pytest.approx(13)
    with pytest.raises(InputError):
        Scale(35, 36, "focalmm")  # needs the pixel size
    with pytest.raises(InputError):
        Scale(13, 10)


def test_the_cone_holds_every_star_of_a_frame_within_the_radius():
    """Whatever the roll and wherever the boresight within the radius, every catalog star
    of the frame is in the cut catalog: verification sees the whole catalog there."""
    sky = random_sky(20000, seed=4)
    camera = Camera.from_fov(1024, 768, 11.42)
    pointing = Pointing(120.0, -30.0, 3.0)
    cut = cut_to_cone(sky, pointing, cone_radius_deg(pointing, camera, 0.1, 40.0))
    rng = np.random.default_rng(5)
    kept = set(cut.ids.tolist())
    for _ in range(50):
        # a boresight on the radius' edge, a random roll, the FOV 10% wide
        angle = rng.uniform(0, 2 * math.pi)
        ra = 120.0 + 3.0 * math.cos(angle) / math.cos(math.radians(-30.0)) * 0.999
        dec = -30.0 + 3.0 * math.sin(angle) * 0.999
        wide = Camera.from_fov(1024, 768, 11.42 * 1.1)
        rows, _, _ = stars_in_view(sky, wide, from_radec_roll(ra, dec, rng.uniform(0, 360)))
        assert set(sky.ids[rows].tolist()) <= kept
    assert len(cut) < len(sky) / 20


@pytest.fixture(scope="module")
def reference():
    return startrack.solve(FRAME, fov_deg=11.42, sky="hipparcos")


def test_pointing_and_scale_hints_solve_the_frame_as_the_fov_does(reference):
    hinted = startrack.solve(FRAME, sky="hipparcos", **HINT)
    assert hinted.solved and _close(hinted, AZI45)
    assert hinted.boresight.separation(reference.boresight).arcsec < 10
    assert hinted.fov_deg == pytest.approx(11.42, abs=0.02)


def test_a_wrong_pointing_hint_is_not_solved_never_wrong():
    result = startrack.solve(FRAME, fov_deg=11.42, sky="hipparcos", ra=200.0, dec=-20.0,
                             radius=5.0)
    assert not result.solved and result.ra_deg is None


def _fits_with_wcs(path: Path, centre, exptime=None) -> Path:
    image = read_image(FRAME)
    wcs = WCS(naxis=2)
    wcs.wcs.ctype = ["RA---TAN", "DEC--TAN"]
    wcs.wcs.crpix = [512.5, 384.5]
    wcs.wcs.crval = list(centre)
    wcs.wcs.cdelt = [-11.42 / 1024, 11.42 / 1024]
    header = wcs.to_header()
    header["DATE-OBS"] = "2019-07-29T20:47:26"
    if exptime is not None:
        header["EXPTIME"] = exptime
    fits.PrimaryHDU(image, header=header).writeto(path)
    return path


def test_a_fits_header_gives_pointing_scale_and_mid_exposure_time(tmp_path, reference):
    path = _fits_with_wcs(tmp_path / "frame.fits", AZI45, exptime=2.0)
    hints = header_hints(path, (1024, 768))
    assert hints.from_header and hints.scale.low < 11.42 < hints.scale.high
    # one field of view, the pointing on a grid a quarter of that wide, the radius grown
    assert hints.pointing.radius_deg == pytest.approx(11.42 * 1.25, rel=0.01)
    centre = SkyCoord(*AZI45, unit="deg")
    hinted = SkyCoord(hints.pointing.ra_deg, hints.pointing.dec_deg, unit="deg")
    assert centre.separation(hinted).deg < 11.42 / 4
    assert header_time(path).isot == "2019-07-29T20:47:27.000"  # DATE-OBS + EXPTIME / 2
    result = startrack.solve(path, sky="hipparcos")  # no option: the header's hints
    # the header's scale is a nominal FOV: the quad search answers first (issue 43)
    assert result.solved and result.frame.solution.method == "quad"
    assert result.to_dict()["diagnostics"]["time_utc"].startswith("2019-07-29T20:47:27")
    # the aberration correction moves the answer by up to 20 arcsec
    assert result.boresight.separation(reference.boresight).arcsec < 30
    ignored = startrack.solve(path, sky="hipparcos", fov_deg=11.42, header_hints=False)
    assert ignored.solved and "time_utc" not in ignored.to_dict()["diagnostics"]
    assert ignored.boresight.separation(reference.boresight).arcsec < 1


def test_a_wrong_header_falls_back_to_the_search(tmp_path):
    """A header pointing elsewhere finds nothing in its cone; the input is then solved as
    if it had no header (the blind search), not left unsolved."""
    path = _fits_with_wcs(tmp_path / "stale.fits", (100.0, -40.0))
    result = startrack.solve(path, sky="hipparcos")
    assert result.solved and _close(result, AZI45, arcsec=40)
    assert result.frame.solution.method == "quad"  # the blind search's


def test_downsample_reports_full_resolution_pixels(reference):
    binned = startrack.solve(FRAME, fov_deg=11.42, sky="hipparcos", downsample=2)
    assert binned.solved
    both = binned.stars.merge(reference.stars, on="catalog_id", suffixes=("", "_ref"))
    assert len(both) >= 20
    assert np.median(np.hypot(both.x - both.x_ref, both.y - both.y_ref)) < 0.5


def test_api_config_preset_gives_camera_and_sky():
    result = startrack.solve(FRAME, config="realsky")
    assert result.solved and _close(result, AZI45)
    assert result.to_dict()["diagnostics"]["sky"]["epoch"] == 2019.6
    assert result.quality["catalog"] == {"kind": "hipparcos", "mag_limit": 7.5}


def _identify(*args):
    return subprocess.run([sys.executable, "-m", "startrack", "identify", *map(str, args)],
                          capture_output=True, text=True)


def test_cli_hints_config_and_bad_hints(reference, tmp_path):
    xy = tmp_path / "stars.csv"
    stars = reference.stars
    xy.write_text("x,y\n" + "\n".join(f"{x},{y}" for x, y in zip(stars.x, stars.y,
                                                                  strict=True)))
    run = _identify(xy, "--config", "realsky", "--ra", 355, "--dec", 58, "--radius", 1,
                    "--format", "json")
    assert run.returncode == 0, run.stderr
    record = json.loads(run.stdout)
    assert record["status"] == "solved"
    assert record["diagnostics"]["camera"]["fov_deg"] == pytest.approx(11.42, abs=0.02)
    assert record["diagnostics"]["sky"]["epoch"] == 2019.6  # the preset's sky
    run = _identify(xy, "--ra", 355, "--dec", 58, "--size", "1024x768")
    assert run.returncode == 2 and "--radius" in run.stderr and "Traceback" not in run.stderr
    run = _identify(xy, "--fov", 11.4, "--scale-low", 10, "--scale-high", 12, "--size",
                    "1024x768")
    assert run.returncode == 2 and "not both" in run.stderr
    run = _identify(xy, "--scale-low", 30, "--scale-high", 40, "--scale-units", "focalmm",
                    "--size", "1024x768")
    assert run.returncode == 2 and "--pixel-size" in run.stderr


def test_calibrate_takes_its_nominal_fov_from_a_fits_header(tmp_path):
    """(calibrate itself is tested in test_calibrate.py; here: where its nominal comes
    from.)"""
    from startrack.cli._calibrate import hinted_fov
    from startrack.solver._inputs import read_input

    path = _fits_with_wcs(tmp_path / "frame.fits", AZI45)
    frames = [read_input(path)]
    # CDELT is the scale at the reference pixel: a pinhole's 1 / f
    pinhole = math.degrees(2 * math.atan(512 * math.radians(11.42 / 1024)))
    assert hinted_fov(frames, None, None, header=True) == pytest.approx(pinhole, rel=1e-6)
    with pytest.raises(InputError, match="--fov"):
        hinted_fov(frames, None, None, header=False)
    scale = Hints(scale=Scale(10.0, 12.0))
    assert hinted_fov(frames, scale, None, header=True) == pytest.approx(11.0)
