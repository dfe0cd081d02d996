"""Star colour as a `compare` axis (--colour-index): every star of a frame takes the level's
B-V, seen through the config's [band]; the base (Sun-like) renders today's frames."""

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from startrack.bench._conditions import Condition, build_conditions, sweep
from startrack.bench._frames import frame_colours, make_frame
from startrack.camera import Camera
from startrack.cli import main
from startrack.simulate import REFERENCE_BV, Band, Effects, SensorModel
from startrack.sky import SkySpec, load_sky

CAMERA = Camera.from_fov(512, 512, 17.5)
BASE = {"noise_px": (0.0,), "false_stars": (0,), "missing": (0.0,), "mag_noise": (0.0,)}
# a blue-pass filter over a silicon-like QE: red stars lose most of their light
BLUE = Band(filter_nm=(350.0, 500.0, 520.0), filter_value=(1.0, 1.0, 0.0),
            qe_nm=(350.0, 500.0, 700.0, 900.0, 1050.0), qe_value=(0.1, 0.5, 0.7, 0.4, 0.05))
BAND_TOML = """[band]
filter_nm = [350.0, 500.0, 520.0]
filter_value = [1.0, 1.0, 0.0]
qe_nm = [350.0, 500.0, 700.0, 900.0, 1050.0]
qe_value = [0.1, 0.5, 0.7, 0.4, 0.05]
"""


@pytest.fixture(scope="module")
def sky():
    return load_sky(SkySpec(kind="random", n_stars=2000, seed=0, mag_limit=6.5))


def test_colour_axis_levels_and_base():
    conds = build_conditions({**BASE, "colour_index": (REFERENCE_BV, 0.0, 1.5)})
    assert conds[0] == Condition()  # the base is Sun-like: no colour
    assert [conds[k].colour_index for k in sweep(conds, "colour_index")] == [0.0, 0.65, 1.5]


def test_the_base_colour_renders_todays_frames_and_a_red_field_fades(sky):
    sensor = SensorModel(exposure_s=0.02)  # short: the faint stars sit near the threshold
    today = make_frame(sky, CAMERA, Condition(), 5, 2, source="images", sensor=sensor)
    base = make_frame(sky, CAMERA, Condition(), 5, 2, source="images", sensor=sensor,
                      effects=Effects(band=BLUE))
    np.testing.assert_array_equal(today.obs.x, base.obs.x)
    counts = [len(make_frame(sky, CAMERA, Condition(colour_index=c), 5, 2, source="images",
                             sensor=sensor, effects=Effects(band=BLUE)).obs.x)
              for c in (0.0, REFERENCE_BV, 2.0)]
    assert counts[0] > counts[1] > counts[2]  # blue stars pass the blue filter, red fade
    # without a band a colour changes nothing
    plain = make_frame(sky, CAMERA, Condition(colour_index=2.0), 5, 2, source="images",
                       sensor=sensor)
    np.testing.assert_array_equal(plain.obs.x, today.obs.x)


def test_false_stars_keep_no_colour(sky):
    from startrack.bench._frames import frame_scene

    scene, _ = frame_scene(sky, CAMERA, Condition(false_stars=3), 1, 0)
    bv = frame_colours(scene, Condition(false_stars=3, colour_index=1.2))
    assert np.all(bv[~scene.is_false] == 1.2) and np.isnan(bv[scene.is_false]).all()
    assert frame_colours(scene, Condition()) is None


@pytest.mark.parametrize(("args", "message"), [
    (["--colour-index", "0,1"], "--colour-index acts on rendered frames"),
    (["--from", "images", "--colour-index", "0,1"], "give a --config with a [band] table"),
    (["--from", "images", "--colour-index", "0,3"], "--colour-index: every value must be"),
])
def test_colour_axis_bad_use_is_one_line(tmp_path, args, message):
    out = tmp_path / "c"
    result = CliRunner().invoke(main, ["compare", "--frames", "2", *args, "--out", str(out)])
    assert result.exit_code == 2 and message in result.output
    assert not out.exists()


def test_compare_reports_solved_against_star_colour(tmp_path):
    cfg = tmp_path / "band.toml"
    cfg.write_text('[camera]\nwidth = 512\nheight = 512\nfov_deg = 17.5\n'
                   '[sky]\nkind = "random"\nn_stars = 2000\nseed = 0\nmag_limit = 6.5\n'
                   '[sensor]\nexposure_s = 0.02\n' + BAND_TOML)
    out = tmp_path / "colour"
    result = CliRunner().invoke(main, [
        "compare", "--config", str(cfg), "--methods", "pyramid", "--frames", "4",
        "--from", "images", "--false-stars", "0", "--colour-index", "0.65,0,2.5",
        "--seed", "2", "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    with open(out / "summary.csv", newline="") as fh:
        summary = {float(r["colour_index"]): r for r in csv.DictReader(fh)}
    assert set(summary) == {0.65, 0.0, 2.5}
    # through a blue filter a field of blue stars shows more of its stars than a Sun-like
    # one, and a field of red stars too few to solve
    recall = {c: float(r["star_recall"]) for c, r in summary.items()}
    assert recall[0.0] > recall[0.65] > recall[2.5]
    assert float(summary[2.5]["solved_rate"]) < float(summary[0.0]["solved_rate"])
    report = (out / "report.md").read_text()
    assert "b_v" in report and "plot_colour_index.png" in {p.name for p in out.iterdir()}
