"""`startrack compare`: files, determinism across seeds, processes, Dask and resume."""

import csv
import json
import shutil
import sys

import pytest
from click.testing import CliRunner

from startrack.bench._runner import COLUMNS, TIMING_COLUMNS
from startrack.cli import main

METHODS = "angle,pyramid"
SMALL = ["--methods", METHODS, "--frames", "5", "--noise-px", "0,1", "--false-stars", "0,2",
         "--missing", "0", "--seed", "7"]


def _run(out, *args, jobs=1):
    return CliRunner().invoke(main, ["compare", *SMALL, "--out", str(out), "--jobs",
                                     str(jobs), *args])


def _numbers(path):
    """frames.csv without its timing columns (the only part allowed to differ)."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    keep = [i for i, name in enumerate(rows[0]) if name not in TIMING_COLUMNS]
    return [[row[i] for i in keep] for row in rows]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare") / "ref"
    result = _run(out)
    assert result.exit_code == 0, result.output
    return out, result


def test_writes_its_files_with_the_expected_columns(reference):
    out, result = reference
    assert {"frames.csv", "summary.csv", "db.csv", "run.json", "plot_noise_px.png",
            "plot_false_stars.png"} <= {p.name for p in out.iterdir()}
    rows = _numbers(out / "frames.csv")
    with open(out / "frames.csv", newline="") as fh:
        assert next(csv.reader(fh)) == COLUMNS
    assert len(rows) == 1 + 3 * 5 * 2  # header + 3 conditions x 5 frames x 2 methods
    with open(out / "summary.csv", newline="") as fh:
        summary = list(csv.DictReader(fh))
    assert len(summary) == 3 * 2
    for key in ("solved_rate", "correct_rate", "wrong_rate", "star_precision", "star_recall",
                "error_median_arcsec", "error_p95_arcsec", "time_median_ms", "time_p95_ms",
                "time_mean_ms", "noise_px", "false_stars", "missing", "mag_noise", "method"):
        assert key in summary[0]
    base = [r for r in summary if r["condition"] == "0"]
    assert all(float(r["correct_rate"]) == 1.0 for r in base)  # exact centroids
    assert json.loads((out / "run.json").read_text())["methods"] == METHODS.split(",")
    assert "frames.csv" in result.output and "angle" in result.output


def test_same_seed_gives_identical_numbers(reference, tmp_path):
    out, _ = reference
    assert _run(tmp_path / "again").exit_code == 0
    assert _numbers(tmp_path / "again" / "frames.csv") == _numbers(out / "frames.csv")
    assert _run(tmp_path / "other", "--seed", "8").exit_code == 0
    assert _numbers(tmp_path / "other" / "frames.csv") != _numbers(out / "frames.csv")


def test_two_processes_give_the_same_numbers(reference, tmp_path):
    out, _ = reference
    result = _run(tmp_path / "par", jobs=2)
    assert result.exit_code == 0, result.output
    assert _numbers(tmp_path / "par" / "frames.csv") == _numbers(out / "frames.csv")


def test_resumed_run_equals_an_uninterrupted_one(reference, tmp_path):
    out, _ = reference
    part = tmp_path / "part"
    assert _run(part).exit_code == 0
    lines = (part / "frames.csv").read_text().splitlines(keepends=True)
    kept = lines[:12]  # header + 11 rows: the last unit is incomplete
    (part / "frames.csv").write_text("".join(kept) + lines[12][: len(lines[12]) // 2])
    (part / "summary.csv").unlink()
    result = _run(part)
    assert result.exit_code == 0, result.output
    assert "resumed: 5 unit(s)" in result.output
    assert _numbers(part / "frames.csv") == _numbers(out / "frames.csv")
    # rows kept from the first run are not rerun (their timings are the originals)
    assert (part / "frames.csv").read_text().splitlines(keepends=True)[:11] == kept[:11]
    assert (part / "summary.csv").is_file()


def test_resume_refuses_results_of_other_code(reference, tmp_path):
    out = tmp_path / "old"
    shutil.copytree(reference[0], out)
    stored = json.loads((out / "run.json").read_text())
    (out / "run.json").write_text(json.dumps({**stored, "code": "0123456789abcdef"}))
    result = _run(out)
    assert result.exit_code == 2 and "differs in: code" in result.output


def test_resume_refuses_a_different_run_unless_told(reference, tmp_path):
    out = tmp_path / "mixed"
    shutil.copytree(reference[0], out)
    result = _run(out, "--seed", "9")
    assert result.exit_code == 2
    assert "different comparison run" in result.output and "seed" in result.output
    result = _run(out, "--seed", "9", "--no-resume")
    assert result.exit_code == 0, result.output
    assert json.loads((out / "run.json").read_text())["seed"] == 9


def test_runs_without_out_never_meet_and_resume_is_asked_for(tmp_path, monkeypatch):
    """Issue 45: `make demo` then `compare --methods pyramid,quad --frames 50` failed with
    "holds a different comparison run". Each run without --out gets its own folder."""
    monkeypatch.chdir(tmp_path)
    first = CliRunner().invoke(main, ["compare", *SMALL, "--jobs", "1"])
    assert first.exit_code == 0, first.output
    second = CliRunner().invoke(main, ["compare", *SMALL, "--methods", "pyramid,quad",
                                       "--jobs", "1"])
    assert second.exit_code == 0, second.output
    runs = sorted(p for p in (tmp_path / "out" / "compare").iterdir() if p.name != "latest")
    assert len(runs) == 2 and all((p / "report.md").is_file() for p in runs)
    assert json.loads((runs[1] / "run.json").read_text())["methods"] == ["pyramid", "quad"]
    latest = tmp_path / "out" / "compare" / "latest"
    assert latest.is_symlink() and latest.resolve() == runs[1].resolve()
    assert f"compare: writing to {runs[1].relative_to(tmp_path)}/" in second.stderr
    # --resume continues the latest run: nothing is left to do, nothing new is made
    again = CliRunner().invoke(main, ["compare", *SMALL, "--methods", "pyramid,quad",
                                      "--jobs", "1", "--resume"])
    assert again.exit_code == 0, again.output
    assert "resumed: 15 unit(s) were already done" in again.stderr
    assert len([p for p in latest.parent.iterdir() if p.name != "latest"]) == 2


def test_resume_without_out_and_without_a_run_is_an_input_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["compare", *SMALL, "--resume"])
    assert result.exit_code == 2 and "no earlier run to resume" in result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, message", [
    (["--methods", "angle,nosuch"], "unknown method"),
    (["--methods", "angle,,pyramid"], "--methods"),
    (["--noise-px", "0,x"], "--noise-px"),
    (["--false-stars", "1.5"], "--false-stars"),
    (["--missing", "0,2"], "--missing"),
    (["--frames", "-3"], "--frames"),
    (["--config", "no/such.toml"], "cannot read config"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "bad"
    result = CliRunner().invoke(main, ["compare", *SMALL, "--out", str(out), *args])
    assert result.exit_code == 2
    assert message in result.output
    assert len(result.output.strip().splitlines()) == 1 or "note:" in result.output
    assert not out.exists()


def test_bad_config_contents(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[camera]\nwidth = 1024\nheight = 1024\nfov_deg = 17.5\nlens = 3\n")
    result = CliRunner().invoke(main, ["compare", *SMALL, "--config", str(cfg),
                                       "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "lens" in result.output
    assert not (tmp_path / "o").exists()


def test_dask_cluster_gives_the_same_numbers(reference, tmp_path):
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    out, _ = reference
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        result = _run(tmp_path / "dask", "--scheduler", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    assert _numbers(tmp_path / "dask" / "frames.csv") == _numbers(out / "frames.csv")


def test_scheduler_without_dask_is_an_input_error(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    out = tmp_path / "nodask"
    result = _run(out, "--scheduler", "tcp://127.0.0.1:1")
    assert result.exit_code == 2 and "startrack[dask]" in result.output
    assert not out.exists()


def test_from_images_runs_the_full_pipeline(tmp_path):
    out = tmp_path / "img"
    result = CliRunner().invoke(main, ["compare", "--methods", "angle", "--frames", "3",
                                       "--from", "images", "--noise-px", "1",
                                       "--false-stars", "0", "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    assert "--noise-px does not apply" in result.output
    with open(out / "frames.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3
    assert all(float(r["noise_px"]) == 0.0 and float(r["centroid_ms"]) > 0 for r in rows)
    assert all(r["correct"] == "1" and int(r["n_observed"]) >= 3 for r in rows)
