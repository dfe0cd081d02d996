"""`startrack identify` end to end, as a user runs it (a subprocess per call)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from repo_paths import DATA, ROOT
from synth import synthetic_frame
from waiting import CHILD_TIMEOUT_S

from startrack.attitude import (
    angle_between_deg,
    boresight_error_arcsec,
    from_quaternion,
    random_attitudes,
)
from startrack.camera import Camera
from startrack.centroids import Centroids, write_centroid_csv
from startrack.sky import random_sky

CAMERA = {"width": 1024, "height": 1024, "fov_deg": 17.5}


def run(*args: str | Path) -> subprocess.CompletedProcess:
    """The command as a user runs it: a new process, its exit code, stdout and stderr."""
    return subprocess.run([sys.executable, "-m", "startrack", "identify", *map(str, args)],
                          capture_output=True, text=True, timeout=CHILD_TIMEOUT_S)


def run_in_process(*args: str | Path) -> subprocess.CompletedProcess:
    """The same through click's runner (no interpreter start-up: for the long error matrix;
    ``main`` is the same group object, with the same one-line error handling)."""
    from click.testing import CliRunner

    from startrack.cli import main

    result = CliRunner().invoke(main, ["identify", *map(str, args)], catch_exceptions=False)
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.stderr)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """Two noisy frames of the random 2000-star sky (what --sky random loads) as CSVs."""
    tmp = tmp_path_factory.mktemp("identify")
    camera = Camera.from_fov(1024, 1024, 17.5)
    catalog = random_sky(2000, seed=0)
    rng = np.random.default_rng(21)
    frames = []
    for rotation in random_attitudes(6, rng):
        frame = synthetic_frame(catalog, camera, rotation, rng, noise_px=0.2)
        if len(frame.obs) >= 10:
            path = tmp / f"frame{len(frames)}.csv"
            # no flux column: the rows are listed brightest first (interfaces.md)
            path.write_text("x,y\n" + "".join(f"{x:.6f},{y:.6f}\n"
                                               for x, y in zip(frame.obs.x, frame.obs.y,
                                                                strict=True)))
            frames.append((path, frame))
    cam_file = tmp / "camera.json"
    cam_file.write_text(json.dumps(CAMERA))
    return tmp, cam_file, catalog, frames[:2]


def _check_solution(record: dict, frame, catalog) -> None:
    assert record["status"] == "solved"
    att = record["attitude"]
    q = np.array(att["quaternion"])
    assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-9
    rotation = from_quaternion(q)
    assert boresight_error_arcsec(rotation, frame.rotation) < 10.0
    assert angle_between_deg(rotation, frame.rotation) * 3600 < 60.0
    assert set(record["timing_ms"]) >= {"centroid", "identify", "total"}
    # Each reported star is the catalog star that was really there.
    assert len(record["stars"]) == len(frame.obs)
    for star in record["stars"]:
        k = int(np.argmin(np.hypot(frame.obs.x - star["x"], frame.obs.y - star["y"])))
        assert star["catalog_id"] == catalog.ids[frame.truth_rows[k]]
        assert star["residual_arcsec"] < 30.0


def test_csv_solves_with_truth_attitude_and_ids(setup):
    tmp, cam, catalog, frames = setup
    path, frame = frames[0]
    out = tmp / "one.json"
    proc = run(path, "--camera", cam, "--sky", "random", "--format", "json", "--output", out)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == ""
    lines = out.read_text().splitlines()
    assert len(lines) == 1
    _check_solution(json.loads(lines[0]), frame, catalog)


def test_json_lines_in_input_order(setup):
    tmp, cam, catalog, frames = setup
    (p0, f0), (p1, f1) = frames
    proc = run(p1, p0, "--camera", cam, "--sky", "random", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["input"] for r in records] == [str(p1), str(p0)]
    _check_solution(records[0], f1, catalog)
    _check_solution(records[1], f0, catalog)


def test_table_and_csv_formats(setup):
    tmp, cam, catalog, frames = setup
    path, frame = frames[0]
    table = run(path, "--camera", cam, "--sky", "random")
    assert table.returncode == 0, table.stderr
    assert "quaternion" in table.stdout and "RA" in table.stdout
    rows = run(path, "--camera", cam, "--sky", "random", "--format", "csv")
    assert rows.returncode == 0, rows.stderr
    lines = rows.stdout.splitlines()
    assert lines[0].split(",")[:4] == ["input", "x", "y", "catalog_id"]
    assert len(lines) == 1 + len(frame.obs)
    assert all(line.startswith(str(path)) for line in lines[1:])


def test_random_centroids_not_solved(setup):
    tmp, cam, _, _ = setup
    rng = np.random.default_rng(5)
    path = tmp / "random.csv"
    write_centroid_csv(path, Centroids(rng.uniform(0, 1023, 25), rng.uniform(0, 1023, 25),
                                       rng.uniform(1, 100, 25)))
    proc = run(path, "--camera", cam, "--sky", "random", "--format", "json")
    assert proc.returncode == 1, proc.stderr
    record = json.loads(proc.stdout)
    assert record["status"] == "not_solved"
    assert record["attitude"] is None and record["stars"] == []


def _bad_inputs(tmp: Path, cam: Path, good: Path) -> dict[str, list]:
    (tmp / "malformed.csv").write_text("x,y\n1.0,2.0\n3.0,oops\n4,5\n")
    (tmp / "nocols.csv").write_text("a,b\n1,2\n")
    (tmp / "two.csv").write_text("x,y\n10,20\n30,40\n")
    (tmp / "badcam.json").write_text(json.dumps({**CAMERA, "focal": 3}))
    common = ["--sky", "random"]
    return {
        "malformed": [tmp / "malformed.csv", "--camera", cam, *common],
        "no x column": [tmp / "nocols.csv", "--camera", cam, *common],
        "missing file": [tmp / "absent.csv", "--camera", cam, *common],
        "unknown method": [good, "--camera", cam, "--method", "nosuch", *common],
        "bad camera": [good, "--camera", tmp / "badcam.json", *common],
        "no camera": [good, *common],
        "bad image": [tmp / "malformed.csv.png", "--fov", "10"],
    }


@pytest.mark.parametrize(("case", "runner"), [
    ("malformed", run), ("no x column", run_in_process),
    ("missing file", run_in_process), ("unknown method", run_in_process),
    ("bad camera", run_in_process), ("no camera", run_in_process),
    ("bad image", run_in_process)])
def test_bad_input_exit_2_one_line_no_output(setup, case, runner):
    tmp, cam, _, frames = setup
    (tmp / "malformed.csv.png").write_bytes(b"not a png")
    args = _bad_inputs(tmp, cam, frames[0][0])[case]
    out_dir = tmp / f"out-{case.replace(' ', '_')}"
    out_dir.mkdir()
    proc = runner(*args, "--format", "json", "--output", out_dir / "result.json")
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert list(out_dir.iterdir()) == []  # nothing written, not even a temporary file


@pytest.mark.parametrize("n_stars", [0, 1, 2])
def test_too_few_stars_is_not_solved_exit_1(setup, n_stars):
    tmp, cam, _, _ = setup
    path = tmp / f"few{n_stars}.csv"
    path.write_text("x,y\n" + "".join(f"{10 + 20 * k},{20 + 9 * k}\n" for k in range(n_stars)))
    proc = run(path, "--camera", cam, "--sky", "random", "--format", "json")
    assert proc.returncode == 1, proc.stderr
    record = json.loads(proc.stdout)
    assert record["status"] == "not_solved" and record["reason"] == "too_few_stars"
    assert record["attitude"] is None and record["stars"] == []
    assert record["method"] == "pyramid"  # no FOV search is run for two stars


def test_batch_answers_every_input_around_a_bad_one(setup):
    tmp, cam, _, frames = setup
    good = [str(f[0]) for f in frames[:2]]
    out = tmp / "batch.jsonl"
    proc = run(good[0], tmp / "absent.csv", good[1], "--camera", cam, "--sky", "random",
               "--format", "json", "--output", out)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "absent.csv" in lines[0]
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["status"] for r in records] == ["solved", "error", "solved"]
    assert records[1]["error"] in lines[0] and records[1]["input"].endswith("absent.csv")


def test_simulated_frame_solves_with_no_options(tmp_path):
    sim = subprocess.run([sys.executable, "-m", "startrack", "simulate", "--frames", "1",
                          "--out", str(tmp_path / "sim")], capture_output=True, text=True,
                         timeout=CHILD_TIMEOUT_S)
    assert sim.returncode == 0, sim.stderr
    sidecar = json.loads((tmp_path / "sim" / "frame_0000.json").read_text())
    proc = run(tmp_path / "sim" / "frame_0000.png", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    record = json.loads(proc.stdout)
    truth = from_quaternion(sidecar["attitude"]["quaternion"])
    assert boresight_error_arcsec(from_quaternion(record["attitude"]["quaternion"]),
                                  truth) < 30.0
    assert len(record["stars"]) >= 5
    assert record["timing_ms"]["centroid"] > 0


# The project checkout sits beside shared/ (as in CI); STARTRACK_REAL_SKY overrides.
REAL_SKY = Path(os.environ.get("STARTRACK_REAL_SKY",
                               ROOT.parent / "shared" / "real-sky"))
# Pointings solved by tetra3 (real-sky/README.md).
REAL_POINTINGS = {"Azi-135": (230.6674, 11.0354), "Azi-45": (172.3687, 57.6492),
                  "Azi135": (296.7571, 11.3137), "Azi45": (355.2046, 58.1518)}


@pytest.mark.slow
@pytest.mark.skipif(not REAL_SKY.is_dir(), reason="real-sky frames not available")
def test_real_sky_frames_match_reference_pointings():
    from startrack.sky import radec_to_vectors

    frames = sorted(REAL_SKY.glob("*.tiff"))
    proc = run(*frames, "--fov", "11.42", "--sky", "hipparcos", "--epoch", "2019.6",
               "--format", "json")
    assert proc.returncode == 0, proc.stderr
    for line in proc.stdout.splitlines():
        record = json.loads(line)
        ref = REAL_POINTINGS[Path(record["input"]).name.split("_")[2]]
        att = record["attitude"]
        got, want = radec_to_vectors(np.array([att["ra_deg"], ref[0]]),
                                     np.array([att["dec_deg"], ref[1]]))
        assert np.degrees(np.arccos(min(1.0, got @ want))) * 3600 < 30.0
        assert len(record["stars"]) >= 15


def test_real_sky_test_frame_solves_within_30_arcsec():
    """tests/data holds one real frame (tetra3's Azi45); it must solve from the image."""
    from startrack.sky import radec_to_vectors

    frame = DATA / "realsky_azi45.png"
    proc = run(frame, "--fov", "11.42", "--sky", "hipparcos", "--epoch", "2019.6",
               "--format", "json")
    assert proc.returncode == 0, proc.stderr
    record = json.loads(proc.stdout)
    att = record["attitude"]
    got, want = radec_to_vectors(np.array([att["ra_deg"], REAL_POINTINGS["Azi45"][0]]),
                                 np.array([att["dec_deg"], REAL_POINTINGS["Azi45"][1]]))
    assert np.degrees(np.arccos(min(1.0, got @ want))) * 3600 < 30.0
    assert len(record["stars"]) >= 30
    assert max(s["residual_arcsec"] for s in record["stars"]) < 40.0


def test_timeout_gives_not_solved_with_reason_timeout(setup):
    """A limit far below one hypothesis's cost trips on every frame: reason "timeout"."""
    tmp, cam, _, frames = setup
    proc = run(frames[0][0], "--camera", cam, "--sky", "random", "--format", "json",
               "--timeout-ms", "1e-6", "--fov-tolerance", "0")
    assert proc.returncode == 1, proc.stderr
    record = json.loads(proc.stdout)
    assert record["status"] == "not_solved" and record["reason"] == "timeout"
