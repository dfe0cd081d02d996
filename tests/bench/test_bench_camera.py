"""The bench's camera conditions: a FOV error and lens distortion, modelled or not."""

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from startrack.bench._conditions import Condition, build_conditions, sweep
from startrack.bench._frames import make_frame, matcher_camera, true_camera
from startrack.camera import Camera, RadialDistortion
from startrack.cli import main
from startrack.sky import random_sky

CAMERA = Camera.from_fov(1024, 1024, 17.5)


def test_cameras_of_a_condition():
    both = Condition(distortion_k1=-0.1, modelled_k1=-0.2, fov_error=0.03)
    assert true_camera(CAMERA, both).distortion == RadialDistortion(k1=pytest.approx(-0.3))
    told = matcher_camera(CAMERA, both)
    assert told.distortion == RadialDistortion(k1=-0.2)
    assert told.fov_deg == pytest.approx(17.5 * 1.03)
    assert (told.cx, told.cy) == (CAMERA.cx, CAMERA.cy)
    assert matcher_camera(CAMERA, Condition(distortion_k1=-0.1)).distortion is None
    assert true_camera(CAMERA, Condition()) == matcher_camera(CAMERA, Condition()) == CAMERA


def test_frames_are_seen_through_the_lens_and_told_the_model():
    sky = random_sky(2000, seed=11)
    plain = make_frame(sky, CAMERA, Condition(), 3, 0)
    lens = make_frame(sky, CAMERA, Condition(modelled_k1=-0.3), 3, 0)
    unknown = make_frame(sky, CAMERA, Condition(distortion_k1=-0.3), 3, 0)
    real = plain.truth_rows >= 0
    # Same stars, moved by the lens; with the model, exactly the true directions again.
    assert np.array_equal(plain.truth_rows, lens.truth_rows)
    assert np.abs(lens.obs.x - plain.obs.x).max() > 3.0
    want = plain.rotation.inv().apply(sky.vectors[plain.truth_rows[real]])
    assert np.abs(lens.obs.vectors[real] - want).max() < 1e-9
    assert np.abs(unknown.obs.vectors[real] - want).max() > 1e-4
    told = make_frame(sky, CAMERA, Condition(fov_error=0.02), 3, 0)
    assert np.array_equal(told.obs.x, plain.obs.x)
    assert told.obs.camera.fov_deg == pytest.approx(17.5 * 1.02)


def test_old_level_tables_still_build_and_camera_variables_sweep():
    levels = {"noise_px": (0.0,), "false_stars": (0,), "missing": (0.0,), "mag_noise": (0.0,)}
    assert build_conditions(levels) == [Condition()]
    conds = build_conditions({**levels, "fov_error": (0.0, 0.02), "modelled_k1": (0.0, -0.3)})
    assert [conds[k].fov_error for k in sweep(conds, "fov_error")] == [0.0, 0.02]
    assert [conds[k].modelled_k1 for k in sweep(conds, "modelled_k1")] == [-0.3, 0.0]


def test_compare_runs_camera_conditions(tmp_path):
    out = tmp_path / "cmp"
    result = CliRunner().invoke(main, [
        "compare", "--methods", "pyramid", "--frames", "4", "--noise-px", "0.2",
        "--false-stars", "0", "--distortion", "0,-0.05", "--modelled-distortion", "0,-0.3",
        "--fov-error", "0,0.002", "--seed", "3", "--jobs", "1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    with open(out / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 4
    modelled = [r for r in rows if float(r["modelled_k1"]) == -0.3]
    assert len(modelled) == 1 and float(modelled[0]["correct_rate"]) == 1.0
    assert "k1_mod" in result.output and "fov_err" in result.output
    bad = CliRunner().invoke(main, ["compare", "--fov-error", "0,0.9", "--out", str(out)])
    assert bad.exit_code != 0
