"""The Python result as an astropy citizen: .wcs, .boresight, .rotation, .quality, a short
repr, Quantities for degrees, and errors that subclass the built-in ones."""


import astropy.units as u
import numpy as np
import pytest
from astropy.coordinates import SkyCoord
from repo_paths import DATA, ROOT
from scipy.spatial.transform import Rotation

import startrack
from startrack.errors import InputError

FRAME = DATA / "realsky_azi45.png"
REAL_SKY = ROOT.parent / "shared" / "real-sky"
REAL_FRAMES = sorted(REAL_SKY.glob("*.tiff")) if REAL_SKY.is_dir() else []


@pytest.fixture(scope="module")
def solver():
    return startrack.Solver(fov_deg=11.42 * u.deg, sky="hipparcos", epoch=2019.6)


@pytest.fixture(scope="module")
def solved(solver):
    return solver.solve(FRAME)


def _wcs_offsets_arcsec(result) -> np.ndarray:
    stars = result.stars
    ra, dec = result.wcs.all_pix2world(stars.x, stars.y, 0)
    return SkyCoord(ra, dec, unit="deg").separation(
        SkyCoord(stars.ra_deg, stars.dec_deg, unit="deg")).arcsec


def _check_wcs(result) -> None:
    """The WCS (SIP fitted to the matched stars) maps each identified star to its catalog
    star: RMS under 5 arcsec (the frames' own centroid noise, ~0.1 px of 40 arcsec, is
    about that: tetra3 reports ~6 arcsec) and none beyond 0.3 px; better than the pinhole
    through the attitude alone (the record's residuals)."""
    offsets = _wcs_offsets_arcsec(result)
    assert np.sqrt(np.mean(offsets ** 2)) < 5.0
    assert offsets.max() < 0.3 * 11.42 * 3600 / 1024
    assert np.sqrt(np.mean(offsets ** 2)) < result.quality["rms_arcsec"]


def test_astropy_objects_of_a_solved_frame(solved):
    assert solved.solved
    assert isinstance(solved.boresight, SkyCoord) and solved.boresight.frame.name == "icrs"
    assert solved.boresight.ra.deg == pytest.approx(solved.ra_deg)
    assert isinstance(solved.rotation, Rotation)
    assert np.allclose(solved.rotation.apply([0, 0, 1]),
                       solved.boresight.cartesian.xyz.value, atol=1e-12)
    assert solved.wcs.sip is not None  # 90+ stars: SIP terms fitted
    assert solved.wcs.pixel_shape == (1024, 768)  # the frame's size, as astropy counts it
    footprint = solved.wcs.calc_footprint()  # needs the size: the four corners on the sky
    assert footprint.shape == (4, 2) and np.isfinite(footprint).all()
    assert solved.quality == solved.to_dict()["quality"]
    text = repr(solved)
    assert len(text) < 300 and "solved" in text and "realsky_azi45.png" in text
    _check_wcs(solved)


@pytest.mark.parametrize("path", REAL_FRAMES, ids=lambda p: p.name[-14:])
def test_wcs_maps_identified_stars_to_the_catalog_on_real_frames(solver, path):
    result = solver.solve(path)
    assert result.solved
    _check_wcs(result)


def test_quantities_are_taken_where_degrees_are(solved):
    same = startrack.solve(FRAME, fov_deg=(11.42 * u.deg).to(u.arcmin), sky="hipparcos",
                           epoch=2019.6, ra=355 * u.deg, dec=58 * u.deg,
                           radius=7200 * u.arcsec)
    assert same.solved
    assert same.boresight.separation(solved.boresight).arcsec < 10
    with pytest.raises(ValueError, match="fov_deg"):
        startrack.Solver(fov_deg=3 * u.m)


def test_api_errors_are_built_in_subclasses(tmp_path):
    with pytest.raises(FileNotFoundError) as missing:
        startrack.solve(tmp_path / "nope.png", fov_deg=11.42)
    assert isinstance(missing.value, InputError) and "no such file" in str(missing.value)
    with pytest.raises(FileNotFoundError):
        startrack.Solver(camera=tmp_path / "nope.json")
    with pytest.raises(ValueError) as bad:
        startrack.Solver(fov_deg=11.42, ra=10.0, dec=95.0, radius=1.0)
    assert isinstance(bad.value, InputError) and str(bad.value).startswith("dec: ")
    assert "--" not in str(bad.value)  # the keyword, not the command line's option
    not_solved = startrack.solve(np.array([[1.0, 2.0], [3.0, 4.0]]), fov_deg=10,
                                 size=(100, 100), sky="hipparcos")
    assert repr(not_solved) == "<SolveResult: not solved (too_few_stars)>"
    assert not_solved.wcs is None and not_solved.boresight is None
    assert not_solved.quality is None and not_solved.rotation is None
