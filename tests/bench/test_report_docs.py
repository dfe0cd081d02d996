"""compare's report.md and --replay; the README's Python API example; docs and help point
to docs/conventions.md; simulate's FITS keywords and sidecar; shipped files are found."""

import csv
import re
import shlex

import numpy as np
import pytest
from click.testing import CliRunner
from repo_paths import ROOT

from startrack.bench._plots import wilson
from startrack.bench._runner import ATTITUDE_COLUMNS
from startrack.cli import main


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "cmp"
    # the command, as given (default levels: 7 conditions), into a test folder; plus
    # one dropout level that leaves some frames too few stars, so that a frame fails
    result = CliRunner().invoke(main, ["compare", "--frames", "20", "--methods",
                                       "angle,pyramid", "--out", str(out), "--jobs", "1",
                                       "--missing", "0,0.9"])
    assert result.exit_code == 0, result.output
    header = result.stdout.splitlines()[0]
    assert "total_med_as" in header and '"' not in header  # no quote characters in names
    assert "thresh_as" in header and "roll_med_as" in header and "recall" in header
    return out, (out / "report.md").read_text()


def _table_rows(text: str) -> list[dict]:
    """The summary table of report.md as dicts of its cells."""
    lines = [line for line in text.splitlines() if line.startswith("| cond |")]
    start = text.splitlines().index(lines[0])
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = []
    for line in text.splitlines()[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append(dict(zip(head, (c.strip() for c in line.strip("|").split("|")),
                             strict=True)))
    return rows


def test_report_stands_alone(report):
    """Issue 45: the threshold as a number per condition, boresight, roll and total errors
    apart, recall beside precision, what the run was and the machine's load, and how to
    read it, before the table."""
    out, text = report
    assert text.index("## How to read this") < text.index("## Run") < text.index("## Summary")
    for row in ("camera", "sky", "frames", "star budget", "threshold", "warm-up", "workers",
                "machine", "load average (1 / 5 / 15 min)"):
        assert f"| {row} |" in text, row
    assert "1024 x 1024 px, horizontal FOV 17.500 deg" in text
    assert re.search(r"\| load average [^|]*\| [\d.]+ / [\d.]+ / [\d.]+ at the start, "
                     r"[\d.]+ / [\d.]+ / [\d.]+ at the end", text)
    rows = _table_rows(text)
    assert {"threshold arcsec", "boresight error arcsec (median / p95)", "star recall",
            "roll error arcsec (median / p95)", "total error arcsec (median / p95)",
            "star precision"} <= set(rows[0])
    pixel_arcsec = np.degrees(np.tan(np.radians(17.5) / 2) / 512) * 3600  # 1 / f_px
    for row in rows:  # max(60", 5 sigma of the per-star noise)
        expected = max(60.0, 5 * float(row["noise px"]) * pixel_arcsec)
        assert float(row["threshold arcsec"]) == pytest.approx(expected, abs=1.0)
        bore, roll, total = (row[f"{k} error arcsec (median / p95)"]
                             for k in ("boresight", "roll", "total"))
        if bore != "-":  # boresight and roll are parts of the total rotation
            assert float(bore.split(" / ")[0]) <= float(total.split(" / ")[0]) + 1e-6
            assert float(roll.split(" / ")[0]) <= float(total.split(" / ")[0]) + 1e-6
    assert any(float(r["threshold arcsec"]) > 600 for r in rows)  # noise 2 px: ~615"
    assert "First timed frames" in text and "- angle: first timed frame" in text


def test_report_has_every_method_provenance_plots_and_intervals(report):
    out, text = report
    for method in ("angle", "pyramid"):
        assert f"| {method} |" in text
    for key in ("startrack", "git commit", "date (UTC)", "host", "CPU", "Python",
                "libraries", "numpy", "scipy", "command"):
        assert key in text
    assert ("startrack compare --methods angle,pyramid --frames 20 --missing 0,0.9 --jobs 1 "
            "--out") in text
    links = re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)
    assert {"plot_noise_px.png", "plot_false_stars.png"} <= set(links)
    assert all((out / link).is_file() for link in links)
    # a rate of 20/20 has the Wilson interval [83.9%, 100.0%]
    assert "100.0% [83.9%, 100.0%]" in text


def test_frames_keep_quaternions_and_a_failed_frame_replays(report):
    out, text = report
    with open(out / "frames.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert set(ATTITUDE_COLUMNS) <= set(rows[0])
    solved = [r for r in rows if r["solved"] == "1"]
    q = np.array([[float(r[c]) for c in ATTITUDE_COLUMNS[4:]] for r in solved])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    commands = re.findall(r"`(startrack compare [^`]*--replay \d+,\d+)`", text)
    assert commands, "frames with too few stars fail: the report lists them"
    args = shlex.split(commands[0])[1:]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert "angle:" in result.output and "pyramid:" in result.output
    assert "true quaternion" in result.output
    # readable: the condition in words, no raw dict, no "nan", and why each failed
    assert "{" not in result.output and "nan" not in result.output
    failed = [line for line in result.output.splitlines()
              if line.startswith(("angle: not solved", "pyramid: not solved"))]
    assert failed and all(": not solved: " in line for line in failed), result.output
    bad = CliRunner().invoke(main, [*args[:-1], "99,0"])
    assert bad.exit_code == 2


def test_full_grid_draws_a_heat_map(tmp_path):
    result = CliRunner().invoke(main, ["compare", "--frames", "3", "--methods", "pyramid",
                                       "--out", str(tmp_path), "--jobs", "1", "--grid", "full",
                                       "--noise-px", "0,1", "--false-stars", "0,3"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "heatmap_correct.png").is_file()
    assert "heatmap_correct.png" in (tmp_path / "report.md").read_text()


def test_wilson_interval():
    low, high = wilson(np.array([0, 10, 20]), np.array([20, 20, 20]))
    assert low[0] == 0 and 0.16 < high[0] < 0.17
    assert low[1] < 0.5 < high[1] and np.isclose(low[1] + high[1], 1.0)
    assert np.isnan(wilson(0, 0)[0])


def test_readme_python_example_runs(monkeypatch):
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python API", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert len(code.strip().splitlines()) == 5
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - our own README
    s = namespace["s"]
    assert s.solved and len(s.stars) >= 30 and "catalog_id" in s.stars
    assert namespace["solver"].solve(ROOT / "tests/data/realsky_azi45.png").solved


def test_docs_and_help_point_to_the_conventions():
    conventions = ROOT / "docs" / "conventions.md"
    assert conventions.is_file()
    text = conventions.read_text()
    for topic in ("Pixel", "quaternion", "Roll", "distortion", "Exit codes", "reason",
                  "fov_deg", "--annotate", "startrack.solve"):
        assert topic in text
    assert "interfaces.md" not in (ROOT / "README.md").read_text()
    assert "docs/conventions.md" in (ROOT / "README.md").read_text()
    for command in ("identify", "simulate", "compare"):
        out = CliRunner().invoke(main, [command, "--help"]).output
        assert "docs/conventions.md" in out and "interfaces.md" not in out.replace(
            "docs/conventions.md", "")


def test_simulate_fits_keywords_and_hipparcos_sidecar(tmp_path):
    import json

    from astropy.io import fits

    result = CliRunner().invoke(main, ["simulate", "--config", "hipparcos20", "--frames",
                                       "1", "--fits", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    header = fits.getheader(tmp_path / "frame_0000.fits")
    assert header["BUNIT"] == "adu" and header["EXPTIME"] > 0 and header["GAIN"] > 0
    sidecar = json.loads((tmp_path / "frame_0000.json").read_text())
    assert "n_stars" not in sidecar["sky"] and "seed" not in sidecar["sky"]
    assert "deg" in sidecar["units"]["angles"]


def test_shipped_files_are_found_and_match_the_checkout():
    from startrack.io._resources import preset_names, resource_path
    from startrack.simulate import load_config

    assert resource_path("data", "iau_star_names.csv").read_bytes() == (
        ROOT / "data" / "iau_star_names.csv").read_bytes()
    assert "hipparcos20" in preset_names()
    assert load_config("hipparcos20").camera.width == 1024
    license_text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in license_text and "Version 2.0" in license_text


@pytest.mark.slow
def test_a_non_editable_install_finds_data_and_configs(tmp_path):
    import subprocess
    import sys
    import sysconfig

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    # the test venv's packages serve as dependencies; startrack itself is installed anew
    (venv / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" /
     "site-packages" / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    py = venv / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(ROOT)],
                   check=True, cwd=tmp_path)
    code = ("import startrack, startrack.outputs._annotate as a, startrack.simulate._config as c;"
            "assert 'site-packages' in startrack.__file__;"
            "print(len(a.star_names()), c.load_config('realsky').camera.width)")
    out = subprocess.run([str(py), "-c", code], check=True, cwd=tmp_path,
                         capture_output=True, text=True).stdout.split()
    assert int(out[0]) > 400 and out[1] == "1024"


def test_rate_error_bars_never_negative_at_full_rates(tmp_path):
    """A 100% rate's Wilson upper end can round a hair below 1; the plot must not fail."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    import pandas as pd

    from startrack.bench._plots import rate_panel

    # n = 6 and 21 round the upper end below 1 at k = n; n = 11 the lower above 0 at k = 0
    rows = pd.DataFrame({"solved_rate": [1.0, 1.0, 0.0], "solved": [6, 21, 0],
                         "frames": [6, 21, 11]})
    fig, ax = plt.subplots()
    rate_panel(ax, rows, np.arange(3.0), "solved_rate", "solved", {})
    plt.close(fig)
