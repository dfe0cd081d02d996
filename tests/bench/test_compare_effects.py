"""The effects as `compare` axes (--cosmic-rays, --stray-light, --temperature): levels,
their conditions, frames that differ only by the effect, and the report's rows."""

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from startrack.bench._conditions import Condition, build_conditions, sweep
from startrack.bench._frames import frame_effects, make_frame
from startrack.camera import Camera
from startrack.cli import main
from startrack.simulate import Effects, SensorModel
from startrack.sky import SkySpec, load_sky

CAMERA = Camera.from_fov(512, 512, 17.5)
BASE = {"noise_px": (0.0,), "false_stars": (0,), "missing": (0.0,), "mag_noise": (0.0,)}


@pytest.fixture(scope="module")
def sky():
    return load_sky(SkySpec(kind="random", n_stars=2000, seed=0, mag_limit=6.5))


def test_effect_axes_sweep_one_at_a_time():
    conds = build_conditions({**BASE, "cosmic_rays": (0.0, 500.0),
                              "stray_light": (0.0, 1e4, 1e5), "temperature_c": (20.0, 60.0)})
    assert len(conds) == 1 + 1 + 2 + 1
    assert [conds[k].stray_light for k in sweep(conds, "stray_light")] == [0.0, 1e4, 1e5]
    assert Condition() == conds[0]  # the base: every effect off
    assert frame_effects(None, conds[0]).is_off
    on = frame_effects(None, Condition(cosmic_rays=5.0, temperature_c=40.0))
    assert on.environment.cosmic_rays == 5.0 and on.detector.temperature_c == 40.0


def test_effect_levels_change_only_the_effect(sky):
    sensor = SensorModel()
    plain = make_frame(sky, CAMERA, Condition(), 3, 1, source="images", sensor=sensor)
    same = make_frame(sky, CAMERA, Condition(), 3, 1, source="images", sensor=sensor,
                      effects=Effects())
    np.testing.assert_array_equal(plain.obs.x, same.obs.x)
    cosmic = make_frame(sky, CAMERA, Condition(cosmic_rays=3000.0), 3, 1, source="images",
                        sensor=sensor)
    assert len(cosmic.obs.x) > len(plain.obs.x)  # the hits add spots
    assert (cosmic.truth_rows == -1).sum() > (plain.truth_rows == -1).sum()
    # stray light raises the noise floor: fewer stars stand out of it
    counts = [len(make_frame(sky, CAMERA, Condition(stray_light=s), 3, 1, source="images",
                             sensor=sensor).obs.x) for s in (0.0, 1e4, 3e4)]
    assert counts[0] > counts[1] > counts[2]


def test_effect_axes_need_rendered_frames(tmp_path):
    out = tmp_path / "c"
    result = CliRunner().invoke(main, ["compare", "--frames", "2", "--cosmic-rays", "0,5",
                                       "--out", str(out)])
    assert result.exit_code == 2
    assert "--cosmic-rays acts on rendered frames: give --from images" in result.output
    assert not out.exists()
    bad = CliRunner().invoke(main, ["compare", "--from", "images", "--frames", "2",
                                    "--temperature", "20,900", "--out", str(out)])
    assert bad.exit_code == 2 and "--temperature" in bad.output


def test_compare_reports_each_effect_axis(tmp_path):
    out = tmp_path / "fx"
    result = CliRunner().invoke(main, [
        "compare", "--methods", "pyramid", "--frames", "3", "--from", "images",
        "--false-stars", "0", "--cosmic-rays", "0,2000", "--stray-light", "0,1e6",
        "--temperature", "20,80", "--seed", "2", "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    with open(out / "summary.csv", newline="") as fh:
        summary = list(csv.DictReader(fh))
    levels = {(float(r["cosmic_rays"]), float(r["stray_light"]), float(r["temperature_c"]))
              for r in summary}
    assert levels == {(0, 0, 20), (2000, 0, 20), (0, 1e6, 20), (0, 0, 80)}
    blinded = next(r for r in summary if float(r["stray_light"]) == 1e6)
    assert float(blinded["solved_rate"]) == 0.0  # 1e6 e-/px/s: every pixel saturates
    assert "cosmic" in result.output and "stray" in result.output
    report = (out / "report.md").read_text()
    assert "| cosmic | stray | temp_c |" in report  # the axes' columns in the summary table
    assert "| 0 | 1e+06 | 20 | pyramid |" in report
    assert {"plot_cosmic_rays.png", "plot_stray_light.png",
            "plot_temperature_c.png"} <= {p.name for p in out.iterdir()}
