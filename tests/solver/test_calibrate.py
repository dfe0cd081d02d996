"""`startrack calibrate`: a distorted camera recovered from frames seen through a wrong one."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from repo_paths import DATA, ROOT

from startrack.attitude import random_attitudes
from startrack.camera import Camera, RadialDistortion, stars_in_view
from startrack.simulate import observe
from startrack.sky import SkySpec, load_sky, resolve_sky

REAL_SKY = ROOT.parent.parent / "shared" / "real-sky"
TRUE = Camera.from_fov(1024, 1024, 20.0, distortion=RadialDistortion(k1=-0.3))


def _write_frames(folder: Path, n: int, seed: int, noise_px: float = 0.2) -> list[Path]:
    """Centroid CSVs of ``n`` random Hipparcos frames through the distorted TRUE camera."""
    catalog = load_sky(resolve_sky(SkySpec(kind="hipparcos"), TRUE), TRUE)
    rng = np.random.default_rng(seed)
    paths = []
    for i, rotation in enumerate(random_attitudes(n, rng)):
        scene = observe(catalog, TRUE, rotation, rng)
        order = np.argsort(scene.mag)
        x = scene.x[order] + rng.normal(0.0, noise_px, len(order))
        y = scene.y[order] + rng.normal(0.0, noise_px, len(order))
        path = folder / f"frame_{i}.csv"
        with path.open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(["x", "y", "flux"])
            writer.writerows(zip(x, y, 10 ** (-0.4 * scene.mag[order]), strict=True))
        paths.append(path)
    return paths


def _calibrate(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "startrack", "calibrate", *map(str, args)],
                          capture_output=True, text=True)


def test_calibrate_recovers_fov_and_k1_from_a_fov_four_percent_off(tmp_path):
    frames = _write_frames(tmp_path, 4, seed=5)
    out = tmp_path / "camera.json"
    run = _calibrate(*frames, "--fov", 20.8, "--size", "1024x1024", "--output", out)
    assert run.returncode == 0, run.stderr
    data = json.loads(out.read_text())
    assert set(data) == {"width", "height", "fov_deg", "cx", "cy", "distortion", "uncertainty"}
    assert set(data["distortion"]) == {"model", "k1", "k2", "k3"}
    assert abs(data["fov_deg"] - 20.0) < 0.02
    assert abs(data["distortion"]["k1"] - (-0.3)) < 0.03
    assert abs(data["cx"] - TRUE.cx) < 10 and abs(data["cy"] - TRUE.cy) < 10
    before = float(run.stdout.split("RMS before:")[1].split("px")[0])
    after = float(run.stdout.split("RMS after:")[1].split("px")[0])
    assert after < 0.5 < 5.0 < before  # 0.2 px centroid noise: ~0.28 px per star in 2-D


def test_calibrate_without_a_camera_or_with_nothing_solvable(tmp_path):
    frame = tmp_path / "few.csv"
    frame.write_text("x,y,flux\n10,10,5\n500,500,3\n")
    out = tmp_path / "camera.json"
    run = _calibrate(frame, "--size", "1024x1024", "--output", out)
    assert run.returncode == 2 and "--fov" in run.stderr and "Traceback" not in run.stderr
    run = _calibrate(frame, "--fov", 20.0, "--size", "1024x1024", "--output", out)
    assert run.returncode == 1 and "nothing written" in run.stderr
    assert not out.exists()
    run = _calibrate(frame, "--fov", 20.0, "--output", out)
    assert run.returncode == 2 and "--size" in run.stderr


@pytest.mark.slow
@pytest.mark.skipif(not REAL_SKY.is_dir(), reason="shared/real-sky not found")
def test_calibrate_real_frames_recovers_their_fov(tmp_path):
    out = tmp_path / "camera.json"
    run = _calibrate(*sorted(REAL_SKY.glob("*.tiff")), "--fov", 11.0, "--epoch", 2019.6,
                     "--output", out)
    assert run.returncode == 0, run.stderr
    assert abs(json.loads(out.read_text())["fov_deg"] - 11.42) < 0.02


def test_the_fit_cuts_outliers_and_recovers_the_camera():
    from startrack.sky import random_sky
    from startrack.solver._calibrate import FrameStars, _fit

    sky = random_sky(4000, seed=3)
    rng = np.random.default_rng(9)
    frames = []
    for rotation in random_attitudes(3, rng):
        rows, x, y = stars_in_view(sky, TRUE, rotation)
        x = x + rng.normal(0.0, 0.1, len(x))
        y = y + rng.normal(0.0, 0.1, len(y))
        frames.append(FrameStars("f", x, y, rotation, np.arange(len(x)), rows))
    bad = frames[0].x.copy()
    bad[:3] += 15.0  # three centroids far from their catalog stars
    frames[0] = FrameStars("f", bad, frames[0].y, frames[0].rotation, frames[0].obs_index,
                           frames[0].cat_index)
    nominal = Camera.from_fov(1024, 1024, 20.4)
    fit = _fit(frames, nominal, sky, terms=1)
    assert not fit.keep[:3].any() and fit.keep[3:].mean() > 0.97
    assert abs(fit.camera.fov_deg - 20.0) < 0.01
    assert abs(fit.camera.distortion.k1 + 0.3) < 0.01
    assert fit.rms < 0.25


def test_an_exact_pinhole_camera_is_reported_as_given_with_its_sigmas(tmp_path):
    """A pinhole frame set calibrated from the exact camera: the data do not reject it, so
    it is written unchanged (no 20.0011 deg or k1 0.002 as if measured), each fitted
    parameter with its 1-sigma; the file reads back as a camera."""
    import startrack.solver._calibrate as cal
    from startrack.camera import load_camera

    pinhole = Camera.from_fov(1024, 1024, 20.0)
    catalog = load_sky(resolve_sky(SkySpec(kind="hipparcos"), pinhole), pinhole)
    rng = np.random.default_rng(12)
    frames = []
    for i, rotation in enumerate(random_attitudes(3, rng)):
        rows, x, y = stars_in_view(catalog, pinhole, rotation)
        x, y = x + rng.normal(0, 0.2, len(x)), y + rng.normal(0, 0.2, len(y))
        frames.append(cal.FrameStars(f"f{i}", x, y, rotation, np.arange(len(x)), rows))
    camera, report = cal._settle(frames, pinhole, catalog, 1, True,
                                 np.ones(sum(len(f.x) for f in frames), bool))
    assert camera.fov_deg == pinhole.fov_deg and camera.distortion is None
    assert (camera.cx, camera.cy) == (pinhole.cx, pinhole.cy)
    by_name = {p.name: p for p in report}
    assert by_name["fov_deg"].status == "as given" and 0 < by_name["fov_deg"].sigma < 0.01
    assert by_name["k1"].status == "as given" and by_name["k1"].sigma > 0
    assert by_name["k2"].status == "not fitted"
    path = tmp_path / "camera.json"
    path.write_text(json.dumps({**camera.to_dict(), "uncertainty": {}}))
    assert load_camera(path).fov_deg == pytest.approx(20.0)


def test_calibrate_takes_a_scale_range_and_a_pointing_cone_instead_of_the_fov(tmp_path):
    frames = _write_frames(tmp_path, 3, seed=5)
    out = tmp_path / "camera.json"
    run = _calibrate(*frames, "--scale-low", 19.5, "--scale-high", 21.5, "--size",
                     "1024x1024", "--output", out)
    assert run.returncode == 0, run.stderr
    assert abs(json.loads(out.read_text())["fov_deg"] - 20.0) < 0.05
    assert "+-" in run.stdout  # every fitted parameter with its 1-sigma
    run = _calibrate(*frames, "--fov", 20.0, "--scale-low", 19.5, "--scale-high", 21.5,
                     "--size", "1024x1024", "--output", out)
    assert run.returncode == 2 and "not both" in run.stderr


def test_calibrate_takes_a_config_preset_camera_and_sky(tmp_path):
    """`calibrate --config realsky` (issue 28: --config presets for calibrate too): the
    preset's camera is the nominal one and its sky (Hp 7.5 at epoch 2019.6) the catalog;
    --fov still overrides the camera."""
    frame = DATA / "realsky_azi45.png"
    out = tmp_path / "camera.json"
    run = _calibrate(frame, "--config", "realsky", "--output", out)
    assert run.returncode == 0, run.stderr
    assert "(nominal 11.4200)" in run.stdout
    assert abs(json.loads(out.read_text())["fov_deg"] - 11.43) < 0.02
    run = _calibrate(frame, "--config", "realsky", "--fov", 11.0, "--output", out,
                     "--overwrite")
    assert run.returncode == 0, run.stderr
    assert "(nominal 11.0000)" in run.stdout


def test_calibrate_with_a_wrong_pointing_hint_solves_nothing_and_says_why(tmp_path):
    """A cone that misses the frame: exit 1, nothing written, the note names the cone."""
    frame = DATA / "realsky_azi45.png"
    out = tmp_path / "camera.json"
    run = _calibrate(frame, "--config", "realsky", "--ra", 100, "--dec", -30, "--radius", 2,
                     "--output", out)
    assert run.returncode == 1 and not out.exists()
    assert "within --radius of --ra/--dec" in run.stderr
