"""The quality record: residuals and the attitude's reported 1-sigma against the scatter
of many seeded simulated frames, and the record's keys."""

import numpy as np
import pytest

import startrack
from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.outputs import format_table
from startrack.sky import SkySpec, load_sky, resolve_sky
from startrack.verify._quality import QUALITY_KEYS, attitude_sigma_rad

CAMERA = Camera.from_fov(1024, 1024, 20.0)
NOISE_PX = 0.4


def _scatter(n_frames: int, seed: int):
    """Boresight and roll errors (arcsec) of ``n_frames`` seeded frames, and the 1-sigma
    each record reported."""
    catalog = load_sky(resolve_sky(SkySpec(kind="random"), CAMERA), CAMERA)  # as solve loads it
    solver = startrack.Solver(fov_deg=20.0, size=(1024, 1024), sky="random",
                              fov_tolerance=0.0, sigma_px=NOISE_PX)
    rng = np.random.default_rng(seed)
    errors, reported = [], []
    for truth in random_attitudes(n_frames, rng):
        rows, x, y = stars_in_view(catalog, CAMERA, truth, margin_px=2.0)
        if len(rows) < 8:
            continue
        x = x + rng.normal(0.0, NOISE_PX, len(x))
        y = y + rng.normal(0.0, NOISE_PX, len(y))
        flux = 10 ** (-0.4 * catalog.mag[rows])
        result = solver.solve(np.column_stack([x, y, flux]))
        if not result.solved:
            continue
        rv = (truth.inv() * result.rotation).as_rotvec() * 206264.806
        errors.append((np.hypot(rv[0], rv[1]), rv[2]))
        q = result.quality
        reported.append((q["sigma_boresight_arcsec"], q["sigma_roll_arcsec"]))
    return np.array(errors), np.array(reported)


def _check(n_frames: int, seed: int, bound: float) -> None:
    errors, reported = _scatter(n_frames, seed)
    assert len(errors) >= 0.9 * n_frames
    # boresight: a 2-D error, its RMS is the reported sqrt(var_x + var_y)
    rms = np.sqrt(np.mean(errors ** 2, axis=0))
    predicted = np.sqrt(np.mean(reported ** 2, axis=0))
    assert rms[0] == pytest.approx(predicted[0], rel=bound)
    assert rms[1] == pytest.approx(predicted[1], rel=bound)


def test_reported_sigma_matches_scatter_over_200_frames():
    _check(200, seed=28, bound=0.20)


def test_attitude_sigma_of_a_symmetric_field():
    """Four stars at angle a around the boresight: info = diag(4 - 2s^2, 4 - 2s^2, 4s^2)
    (s = sin a), the textbook result the record's sigma comes from."""
    a = np.radians(5.0)
    s, c = np.sin(a), np.cos(a)
    b = np.array([[s, 0, c], [-s, 0, c], [0, s, c], [0, -s, c]])
    bore, roll = attitude_sigma_rad(b, 1e-5)
    assert bore == pytest.approx(1e-5 * np.sqrt(2 / (4 - 2 * s * s)), rel=1e-9)
    assert roll == pytest.approx(1e-5 / np.sqrt(4 * s * s), rel=1e-9)


def test_quality_record_keys_and_real_sky_drops_random_keys():
    frame = "tests/data/realsky_azi45.png"
    record = startrack.solve(frame, fov_deg=11.42, sky="hipparcos").to_dict()
    q = record["quality"]
    assert tuple(q) == QUALITY_KEYS
    assert q["n_matched"] == len(record["stars"])
    res = np.array([s["residual_arcsec"] for s in record["stars"]])
    assert q["rms_arcsec"] == pytest.approx(np.sqrt(np.mean(res ** 2)))
    assert q["max_arcsec"] == pytest.approx(res.max())
    assert q["false_match_probability"] == record["false_probability"]
    assert q["catalog"] == {"kind": "hipparcos", "mag_limit": 7.5}
    assert 0 < q["sigma_boresight_arcsec"] < q["sigma_roll_arcsec"]
    assert f"boresight {q['sigma_boresight_arcsec']:.2f} arcsec" in format_table(record)
    assert "n_stars" not in record["diagnostics"]["sky"]
    assert "seed" not in record["diagnostics"]["sky"]
