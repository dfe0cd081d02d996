"""A frame's time tag off by a seeded error while the camera turns ([frames]
time_tag_error_s): the frame shows the attitude at its true time, the tag says another, and
an attitude reported at the tag is off by rate x error (docs/simulation.md)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

import startrack
from startrack.cli import main
from startrack.errors import InputError
from startrack.io import read_sidecar
from startrack.simulate import simulation_trajectory
from startrack.simulate._trajectory import time_tag_errors

RATE_DPS = (1.0, 0.5, 0.0)
FPS = 5.0
SIGMA_S = 0.2


def test_errors_are_seeded_per_frame_and_off_by_default():
    start = Rotation.identity()
    plan = simulation_trajectory(start, RATE_DPS, FPS, None, 600, SIGMA_S, seed=4)
    whole = np.concatenate([plan.block(0, 256).tag_times, plan.block(256, 344).tag_times])
    true = np.arange(600) / FPS
    errors = whole - true
    # a frame's error is its own, whatever block it is computed in
    np.testing.assert_allclose(plan.block(300, 5).tag_times - true[300:305], errors[300:305],
                               atol=1e-12)
    np.testing.assert_allclose(errors, time_tag_errors(4, 0, 600, SIGMA_S), atol=1e-12)
    assert np.std(errors) == pytest.approx(SIGMA_S, rel=0.1) and abs(np.mean(errors)) < 0.03
    assert not np.array_equal(errors, time_tag_errors(5, 0, 600, SIGMA_S))
    assert simulation_trajectory(start, RATE_DPS, FPS, None, 5).block(0, 5).tag_times is None
    with pytest.raises(InputError, match="time_tag_error_s needs a sequence"):
        simulation_trajectory(start, RATE_DPS, None, None, 5, SIGMA_S)


def _simulate(tmp_path, sigma):
    (tmp_path / "cam.json").write_text('{"width": 320, "height": 240, "fov_deg": 30.0}')
    cfg = tmp_path / "tag.toml"
    cfg.write_text(f"[frames]\ntime_tag_error_s = {sigma}\nseed = 3\n")
    out = tmp_path / f"out{sigma}"
    result = CliRunner().invoke(main, [
        "simulate", "--config", str(cfg), "--camera", str(tmp_path / "cam.json"),
        "--frames", "3", "--fps", str(FPS), "--rate", ",".join(map(str, RATE_DPS)),
        "--attitude", "80,25,10", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_the_frame_shows_the_true_time_and_carries_the_tag(tmp_path):
    out = _simulate(tmp_path, SIGMA_S)
    plain = _simulate(tmp_path, 0.0)
    w = np.radians(RATE_DPS)
    r0 = read_sidecar(out / "frame_0000.json")[2]
    for k in range(3):
        side = json.loads((out / f"frame_{k:04d}.json").read_text())
        assert side["true_time_s"] == pytest.approx(k / FPS)
        assert side["time_s"] == pytest.approx(k / FPS + side["time_tag_error_s"])
        assert side["time_tag_error_s"] != 0.0
        # the pixels and the truth are those of the true time: the same as untagged frames
        assert (out / f"frame_{k:04d}.png").read_bytes() == \
            (plain / f"frame_{k:04d}.png").read_bytes()
        untagged = json.loads((plain / f"frame_{k:04d}.json").read_text())
        assert "true_time_s" not in untagged and untagged["time_s"] == pytest.approx(k / FPS)
        truth = read_sidecar(out / f"frame_{k:04d}.json")[2]
        expected = r0 * Rotation.from_rotvec(w * k / FPS)
        assert (truth.inv() * expected).magnitude() < 1e-9


def test_an_attitude_reported_at_the_tag_is_off_by_rate_times_error(tmp_path):
    out = _simulate(tmp_path, SIGMA_S)
    w = np.radians(RATE_DPS)
    r0 = read_sidecar(out / "frame_0000.json")[2]
    rate = np.degrees(np.linalg.norm(w))
    for k in (1, 2):
        side = json.loads((out / f"frame_{k:04d}.json").read_text())
        result = startrack.solve(out / f"frame_{k:04d}.png", fov_deg=30.0, sky="random")
        assert result.solved
        solved = Rotation.from_quat(result.quaternion, scalar_first=True)
        truth = read_sidecar(out / f"frame_{k:04d}.json")[2]
        at_tag = r0 * Rotation.from_rotvec(w * side["time_s"])  # what the tag says
        error_deg = np.degrees((solved.inv() * at_tag).magnitude())
        expected_deg = rate * abs(side["time_tag_error_s"])
        assert expected_deg > 0.02  # well above the solver's own error
        assert np.degrees((solved.inv() * truth).magnitude()) < 0.01
        assert error_deg == pytest.approx(expected_deg, rel=0.05, abs=0.005)


def test_bad_time_tag_settings_are_one_line_errors(tmp_path):
    from startrack.simulate import config_from_dict

    with pytest.raises(InputError, match=r"cfg \[frames\]: time_tag_error_s"):
        config_from_dict({"frames": {"time_tag_error_s": -0.1}}, "cfg")
    cfg = tmp_path / "tag.toml"
    cfg.write_text("[frames]\ntime_tag_error_s = 0.01\n")
    out = tmp_path / "o"
    result = CliRunner().invoke(main, ["simulate", "--config", str(cfg), "--out", str(out)])
    assert result.exit_code == 2 and "time_tag_error_s needs a sequence (--fps)" in result.output
    assert not out.exists()
