"""Annual aberration: against astropy's GCRS, and the attitude fix end to end."""

import json
import subprocess
import sys

import numpy as np
import pytest

from startrack.attitude import boresight_error_arcsec, from_radec_roll
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.errors import InputError
from startrack.simulate import observe
from startrack.sky import SkySpec, load_sky, radec_to_vectors, resolve_sky, vectors_to_radec
from startrack.solver._aberration import aberrate, earth_velocity, parse_time
from startrack.solver._pipeline import FrameInput, Options, Pipeline

WHEN = "2019-07-29T20:47:26Z"


def test_aberration_matches_astropy_gcrs():
    import astropy.units as u
    from astropy.coordinates import GCRS, ICRS, SkyCoord, get_sun

    t = parse_time(WHEN)
    rng = np.random.default_rng(2)
    v = rng.normal(size=(300, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    ra, dec = vectors_to_radec(v)
    sun = get_sun(t).transform_to(ICRS())
    elongation = SkyCoord(ra * u.deg, dec * u.deg, frame="icrs").separation(sun).rad
    far = elongation > np.radians(30.0)
    gcrs = SkyCoord(ra[far] * u.deg, dec[far] * u.deg, frame="icrs").transform_to(
        GCRS(obstime=t))
    want = radec_to_vectors(gcrs.ra.deg, gcrs.dec.deg)
    got = aberrate(v[far], earth_velocity(t))
    # astropy adds the Sun's light deflection (~4 mas * cot(elongation / 2)), which we omit:
    # tens of milliarcseconds at most this far from the Sun, 0.2% of the effect.
    diff = np.degrees(np.linalg.norm(got - want, axis=1)) * 3600  # chord: exact when small
    assert diff.max() < 0.05
    assert np.median(diff) < 0.01
    shift = np.degrees(np.linalg.norm(got - v[far], axis=1)) * 3600
    assert 19.0 < shift.max() < 21.0  # v/c of the Earth's ~30 km/s
    back = aberrate(got, -earth_velocity(t))
    assert np.abs(back - v[far]).max() < 1e-12


def test_parse_time():
    assert parse_time("2019-07-29T22:47:26+02:00").utc.isot.startswith("2019-07-29T20:47:26")
    assert parse_time("2019-07-29T20:47:26").utc.isot == parse_time(WHEN).utc.isot
    with pytest.raises(InputError, match="ISO 8601"):
        parse_time("yesterday")


def _apex_perpendicular_attitude(t):
    """An attitude whose boresight is 90 deg from the Earth's motion (the full 20")."""
    beta = earth_velocity(t)
    b = np.cross(beta, [0.0, 0.0, 1.0])
    ra, dec = vectors_to_radec(b / np.linalg.norm(b))
    return from_radec_roll(float(ra), float(dec), 30.0)


def test_identify_with_time_recovers_the_true_attitude():
    t = parse_time(WHEN)
    camera = Camera.from_fov(1024, 1024, 20.0)
    catalog = load_sky(resolve_sky(SkySpec(kind="hipparcos"), camera), camera)
    rotation = _apex_perpendicular_attitude(t)
    from startrack.solver._aberration import apparent_catalog

    scene = observe(apparent_catalog(catalog, t), camera, rotation, np.random.default_rng(0))
    order = np.argsort(scene.mag)
    frame = FrameInput("aberrated", Centroids(scene.x[order], scene.y[order],
                                              10 ** (-0.4 * scene.mag[order])))
    errors = {}
    for name, when in (("with", t), ("without", None)):
        result = Pipeline(Options(camera=camera, sky="hipparcos", time=when)).solve(frame)
        assert result.solution.solved
        errors[name] = boresight_error_arcsec(result.solution.rotation, rotation)
    assert errors["with"] < 1.0
    assert 18.0 < errors["without"] < 21.0


def test_simulate_and_identify_fits_with_date_obs(tmp_path):
    t = parse_time(WHEN)
    ra, dec, roll = (float(a) for a in (*vectors_to_radec(
        _apex_perpendicular_attitude(t).apply([0.0, 0.0, 1.0])), 30.0))
    sim = subprocess.run([sys.executable, "-m", "startrack", "simulate", "--frames", "1",
                          "--attitude", f"{ra},{dec},{roll}", "--time", WHEN, "--fits",
                          "--out", str(tmp_path)], capture_output=True, text=True)
    assert sim.returncode == 0, sim.stderr
    truth = json.loads((tmp_path / "frame_0000.json").read_text())
    assert truth["time_utc"].startswith("2019-07-29T20:47:26")

    def pointing(*extra):
        run = subprocess.run([sys.executable, "-m", "startrack", "identify", *extra,
                              "--format", "json"], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        att = json.loads(run.stdout)["attitude"]
        return boresight_error_arcsec(from_radec_roll(att["ra_deg"], att["dec_deg"], 0.0),
                                      from_radec_roll(ra, dec, 0.0))

    assert pointing(str(tmp_path / "frame_0000.fits")) < 3.0  # DATE-OBS read
    assert pointing(str(tmp_path / "frame_0000.png")) > 15.0  # a PNG has no time
    assert pointing(str(tmp_path / "frame_0000.png"), "--time", WHEN) < 3.0
