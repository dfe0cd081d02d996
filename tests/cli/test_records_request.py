"""Issue 45: records that tell the truth about the request (the method and sky asked for,
every stage tried in order, the hints, the fitted FOV in the table), a "not solved" that
says what to try, and the small corners a newcomer met (API errors naming keywords,
load_sky's magnitude cut, the README's method table)."""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from repo_paths import ROOT

import startrack
from startrack.camera import Camera
from startrack.cli import main
from startrack.defaults import BUILTIN_METHODS
from startrack.sky import SkySpec, load_sky

FRAME = ROOT / "tests" / "data" / "realsky_azi45.png"  # 11.42 deg wide


def _identify(*args):
    result = CliRunner().invoke(main, ["identify", str(FRAME), *args])
    return result, result.stdout


def test_a_nominal_fov_30_percent_off_says_what_was_tried_and_what_to_try():
    result, out = _identify("--fov", "14.85", "--format", "json")
    assert result.exit_code == 1, result.output
    record = json.loads(out)
    assert record["status"] == "not_solved" and record["method"] == "pyramid"  # as asked
    request = record["requested"]
    assert request["method"] == "pyramid" and request["fov_deg"] == 14.85
    assert request["fov_tolerance"] == 0.1 and request["sky"]["kind"] == "hipparcos"
    steps = record["steps"]
    # the search first, then the configured method's first look (issue 43)
    first = [("quad", "hipparcos"), ("pyramid", "hipparcos"), ("quad", "gaia")]
    # the same stages again past the 8 brightest spots, then that look's own line
    # (issue 49, startrack.solver._deeper)
    assert [(s["method"], s["sky"]["kind"]) for s in steps] == first + first + [
        ("quad", "hipparcos")]
    assert steps[-1]["stage"] == "second look, past the 8 brightest spots"
    assert all(s["result"] == "no_match" for s in steps)
    assert steps[0]["fov_deg"] == pytest.approx([13.365, 16.335])
    # diagnostics.sky is the last stage's (gaia); the request keeps the sky asked for
    assert record["diagnostics"]["sky"]["kind"] == "gaia"
    note = [line for line in result.stderr.splitlines() if "--fov-tolerance" in line]
    assert len(note) == 1 and "--fov-tolerance 0.4 (searches 8.91 to 20.79 deg)" in note[0]
    assert "leave out --fov" in note[0]


def test_the_suggestion_solves_and_the_table_shows_the_fitted_fov_and_the_stages():
    result, out = _identify("--fov", "14.85", "--fov-tolerance", "0.4")
    assert result.exit_code == 0, result.output
    assert "status: solved (method quad" in out
    fov = re.search(r"field of view: ([\d.]+) deg", out)
    assert fov and float(fov.group(1)) == pytest.approx(11.42, abs=0.05)
    assert "requested: method pyramid, sky hipparcos" in out and "FOV 14.85 deg +-40%" in out
    # a tolerance this wide is a range, its centre no nominal FOV: no first look there
    # (startrack.solver._nominal.FIRST_LOOK_MAX_TOLERANCE), the range searched at once
    # (one stage: the table lists no stages)
    assert "first look" not in out
    record = json.loads(_identify("--fov", "14.85", "--fov-tolerance", "0.4",
                                  "--format", "json")[1])
    assert [(s["stage"], s["method"], s["result"]) for s in record["steps"]] == [
        ("FOV search", "quad", "solved")]
    assert record["steps"][0]["fov_deg"] == pytest.approx([8.91, 20.79], abs=0.005)
    assert "--fov-tolerance" not in result.stderr  # solved: nothing to suggest


def test_hints_used_are_echoed():
    result, out = _identify("--ra", "355", "--dec", "58", "--radius", "2", "--scale-low", "10",
                            "--scale-high", "13", "--sky", "hipparcos", "--epoch", "2019.6",
                            "--format", "json")
    assert result.exit_code == 0, result.output
    record = json.loads(out)
    assert record["requested"]["hints"] == {
        "ra_deg": 355.0, "dec_deg": 58.0, "radius_deg": 2.0, "scale_low": 10.0,
        "scale_high": 13.0, "scale_units": "degwidth", "from": "user"}
    assert record["requested"]["fov_deg"] is None  # no FOV: the scale range searched
    assert record["steps"] and record["steps"][-1]["result"] == "solved"


def test_the_sidecar_sky_is_the_requested_one(tmp_path):
    sim = CliRunner().invoke(main, ["simulate", "--config", str(ROOT / "configs" /
                                                                  "hipparcos20.toml"),
                                    "--frames", "1", "--out", str(tmp_path / "sim"), "-q"])
    assert sim.exit_code == 0, sim.output
    sidecar = json.loads((tmp_path / "sim" / "frame_0000.json").read_text())
    result = CliRunner().invoke(main, ["identify", str(tmp_path / "sim" / "frame_0000.png"),
                                       "--format", "json"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    asked = record["requested"]["sky"]
    assert asked["kind"] == sidecar["sky"]["kind"] == "hipparcos"
    assert asked["mag_limit"] == sidecar["sky"]["mag_limit"]
    assert record["requested"]["fov_deg"] == pytest.approx(sidecar["camera"]["fov_deg"])
    assert [s["method"] for s in record["steps"]][0] == "quad"  # the search first


def test_api_errors_name_keywords_not_options():
    centroids = np.array([[10.0, 20.0], [300.0, 40.0], [500.0, 600.0], [50.0, 700.0]])
    with pytest.raises(ValueError) as caught:
        startrack.solve(centroids)  # no FOV and no size: a blind search needs the size
    message = str(caught.value)
    assert "size=(width, height)" in message and "fov_deg=" in message
    assert "--" not in message


def test_load_sky_by_name_with_a_camera_takes_the_default_magnitude_cut():
    camera = Camera.from_fov(1024, 1024, 20.0)
    sky = load_sky("hipparcos", camera)
    assert sky.mag.max() <= 6.5 + 1e-9 and len(sky) < 10_000  # not all 116,370 stars
    assert sky.source["mag_limit"] == pytest.approx(6.5)
    deep = load_sky(SkySpec(kind="hipparcos", mag_limit=8.0), camera)  # a spec: as given
    assert deep.mag.max() > 7.5 and len(deep) > len(sky)


def test_readme_method_tables_name_every_built_in_method():
    rows = "\n".join(line for line in (ROOT / "README.md").read_text().splitlines()
                     if line.startswith("|"))
    assert [m for m in BUILTIN_METHODS if f"`{m}`" not in rows] == []
    assert "| `quad` |" in rows
