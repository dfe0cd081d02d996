"""Tracking through the command line and the API: ``identify --track`` on CSV and PNG
sequences, ``--prior`` on a single frame, ``simulate --fps/--rate/--profile`` and
``Solver(track=True)``."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from repo_paths import ROOT
from scipy.spatial.transform import Rotation

import startrack
from startrack.attitude import boresight_error_arcsec, from_quaternion, to_radec_roll
from startrack.bench._tracking_bench import TrackCondition, make_sequence
from startrack.centroids import Centroids, write_centroid_csv
from startrack.cli import main

HIP = ["--sky", "hipparcos", "--fov", "20", "--size", "1024x1024"]


def invoke(*args):
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture(scope="module")
def csv_sequence(tmp_path_factory, hip_db):
    """Six frames at 10 fps turning at (1, 0.5, 2) deg/s, as centroid CSVs."""
    tmp = tmp_path_factory.mktemp("track")
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 6, 10.0, seed=12)
    paths = []
    for k, frame in enumerate(seq):
        path = tmp / f"f{k}.csv"
        write_centroid_csv(path, Centroids(frame.obs.x, frame.obs.y,
                                           np.arange(len(frame.obs), 0, -1.0)))
        paths.append(path)
    return paths, seq


def _records(stdout: str) -> list[dict]:
    return [json.loads(line) for line in stdout.splitlines()]


def test_identify_track_on_csv_sequence(csv_sequence):
    paths, seq = csv_sequence
    code, out, err = invoke("identify", "--track", *HIP, "--format", "json", *paths)
    assert code == 0, err
    records = _records(out)
    assert [r["mode"] for r in records] == ["lost_in_space"] + ["tracking"] * 5
    assert [r["lock"] for r in records] == ["acquired"] + ["tracking"] * 5
    for r, frame in zip(records, seq, strict=True):
        rot = from_quaternion(r["attitude"]["quaternion"])
        assert boresight_error_arcsec(rot, frame.rotation) < 30.0
    # Without --track every frame is lost-in-space and carries no lock.
    code, out, _ = invoke("identify", *HIP, "--format", "json", *paths[:2])
    assert [(r["mode"], "lock" in r) for r in _records(out)] == [("lost_in_space", False)] * 2


def _assert_true_identities(records, seq, catalog):
    """Every record solved, pointing within 30", each star named its true catalog star."""
    for r, frame in zip(records, seq, strict=True):
        assert r["status"] == "solved"
        rot = from_quaternion(r["attitude"]["quaternion"])
        assert boresight_error_arcsec(rot, frame.rotation) < 30.0
        for star in r["stars"]:  # the centroid it names, as written to the CSV
            d2 = (frame.obs.x - star["x"]) ** 2 + (frame.obs.y - star["y"]) ** 2
            assert d2.min() < 1e-4
            row = frame.truth_rows[np.argmin(d2)]
            assert row >= 0 and catalog.ids[row] == star["catalog_id"]


@pytest.mark.parametrize("fov", ["20.8", None])
def test_track_through_the_camera_lost_in_space_fitted(csv_sequence, hip_db, fov):
    """A field of view 4% off, or none at all: the first frame is solved as a single input
    is (its FOV fitted, or searched for), and the later ones are tracked through the
    camera that fit found."""
    paths, seq = csv_sequence
    size = ["--sky", "hipparcos", "--size", "1024x1024"]
    code, out, err = invoke("identify", "--track", *size, *(["--fov", fov] if fov else []),
                            "--format", "json", *paths)
    assert code == 0, err
    records = _records(out)
    assert [r["mode"] for r in records] == ["lost_in_space"] + ["tracking"] * 5
    assert all(r["fov_deg"] == pytest.approx(20.0, abs=0.05) for r in records)
    _assert_true_identities(records, seq, hip_db.catalog)


def test_unreadable_frame_in_a_sequence_is_a_frame_without_answer(csv_sequence, tmp_path):
    paths, _ = csv_sequence
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,oops\n")
    code, out, err = invoke("identify", "--track", *HIP, "--format", "json", paths[0], bad,
                            paths[2], paths[3])
    assert code == 2 and err.count("\n") == 1 and "bad.csv" in err
    records = _records(out)
    assert [r["status"] for r in records] == ["solved", "error", "solved", "solved"]
    assert [r.get("mode") for r in records] == ["lost_in_space", None, "tracking", "tracking"]


def test_prior_on_a_single_frame(csv_sequence):
    paths, seq = csv_sequence
    truth = seq[3].rotation
    near = to_radec_roll(truth * Rotation.from_rotvec([0.004, -0.003, 0.002]))
    code, out, err = invoke("identify", *HIP, "--format", "json", "--prior",
                            ",".join(f"{v:.6f}" for v in near), "--prior-sigma-deg", "0.5",
                            paths[3])
    assert code == 0, err
    record = _records(out)[0]
    assert record["mode"] == "tracking" and "lock" not in record
    assert boresight_error_arcsec(from_quaternion(record["attitude"]["quaternion"]),
                                  truth) < 30.0
    # A prior 30 deg off: tracking finds nothing, lost-in-space solves it.
    far = to_radec_roll(truth * Rotation.from_rotvec([math.radians(30), 0, 0]))
    code, out, _ = invoke("identify", *HIP, "--format", "json", "--prior",
                          ",".join(map(str, far)), "--prior-sigma-deg", "0.2", paths[3])
    record = _records(out)[0]
    assert code == 0 and record["mode"] == "lost_in_space"
    assert boresight_error_arcsec(from_quaternion(record["attitude"]["quaternion"]),
                                  truth) < 30.0


@pytest.mark.parametrize("value", ["1,2", "a,b,c", "0,95,0"])
def test_bad_prior_is_exit_2(csv_sequence, value):
    paths, _ = csv_sequence
    code, out, err = invoke("identify", *HIP, "--prior", value, paths[0])
    assert code == 2 and out == "" and err.count("\n") == 1


def test_simulate_sequence_png_and_identify_track(tmp_path):
    cam = tmp_path / "cam.json"
    cam.write_text(json.dumps({"width": 512, "height": 512, "fov_deg": 20.0}))
    out = tmp_path / "sim"
    code, _, err = invoke("simulate", "--camera", cam, "--sky", "hipparcos", "--mag-limit",
                          "6.5", "--frames", "4", "--fps", "10", "--rate", "1,0.5,2",
                          "--attitude", "80,20,30", "--seed", "4", "--out", out)
    assert code == 0, err
    truths = [from_quaternion(json.loads((out / f"frame_{k:04d}.json").read_text())
                              ["attitude"]["quaternion"]) for k in range(4)]
    step = (truths[0].inv() * truths[3]).as_rotvec()
    assert np.allclose(np.degrees(step), np.array([1.0, 0.5, 2.0]) * 0.3, atol=1e-9)
    code, stdout, err = invoke("identify", "--track", "--format", "json",
                               *sorted(out.glob("frame_*.png")))
    assert code == 0, err
    records = _records(stdout)
    assert [r["mode"] for r in records] == ["lost_in_space"] + ["tracking"] * 3
    for r, truth in zip(records, truths, strict=True):
        assert boresight_error_arcsec(from_quaternion(r["attitude"]["quaternion"]),
                                      truth) < 60.0


def test_simulate_profile_slews(tmp_path):
    q1 = Rotation.from_euler("zyx", [10, 5, 0], degrees=True).as_quat(scalar_first=True)
    profile = tmp_path / "slew.csv"
    profile.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.5," + ",".join(map(str, q1)) + "\n")
    out = tmp_path / "sim"
    args = ("simulate", "--sky", "random", "--fps", "4", "--profile", profile, "--out", out)
    code, _, err = invoke(*args)
    assert code == 0, err
    sidecars = sorted(out.glob("frame_*.json"))
    assert len(sidecars) == 3  # t = 0, 0.25, 0.5 s
    last = from_quaternion(json.loads(sidecars[-1].read_text())["attitude"]["quaternion"])
    assert np.degrees((last.inv() * Rotation.from_quat(q1, scalar_first=True)).magnitude()) \
        < 1e-9
    code, _, err = invoke("simulate", "--sky", "random", "--profile", profile, "--out", out)
    assert code == 2 and "--profile needs --fps" in err


def test_solver_keeps_state_between_frames(csv_sequence, hip_db):
    _, seq = csv_sequence
    solver = startrack.Solver(fov_deg=20.0, size=(1024, 1024), sky="hipparcos", track=True)
    arrays = [np.column_stack([f.obs.x, f.obs.y]) for f in seq[:3]]
    results = [solver.solve(a) for a in arrays]
    assert [r.mode for r in results] == ["lost_in_space", "tracking", "tracking"]
    assert results[2].lock == "tracking" and results[2].to_dict()["mode"] == "tracking"
    solver.reset()
    assert solver.solve(arrays[0]).mode == "lost_in_space"


def test_compare_tracking_mode(tmp_path):
    import pandas as pd

    out = tmp_path / "cmp"
    code, stdout, err = invoke("compare", "--mode", "tracking", "--frames", "6", "--rates",
                               "0,5", "--noise-px", "0.5", "--false-stars", "1", "--missing",
                               "0", "--out", out)
    assert code == 0, err
    summary = pd.read_csv(out / "summary.csv")
    assert set(summary["method"]) >= {"pyramid+track", "pyramid"}
    assert sorted(set(summary["rate_dps"])) == [0.0, 5.0]
    tracked = summary[summary["method"] == "pyramid+track"]
    assert (tracked["tracked_rate"] >= 4 / 6).all() and (tracked["wrong"] == 0).all()
    assert (summary[summary["method"] == "pyramid"]["tracked_rate"] == 0).all()
    assert (out / "report.md").read_text().startswith("# Tracking comparison")
    assert (out / "tracking_rate_dps.png").is_file() and "pyramid+track" in stdout


@pytest.mark.slow
def test_track_a_narrow_field_on_the_deep_sky(tmp_path):
    """A 3 deg camera on the Gaia sky (configs/narrow_gaia.toml), whose pair table is over
    budget: lost-in-space by the quad search, as a single frame, then tracking, every
    star named right. Builds Gaia pattern tables on a fresh cache."""
    out = tmp_path / "narrow"
    config = ROOT / "configs" / "narrow_gaia.toml"
    code, _, err = invoke("simulate", "--config", config, "--frames", "4", "--fps", "5",
                          "--rate", "0.05,0.02,0.3", "--seed", "3", "--out", out)
    assert code == 0, err
    frames = sorted(out.glob("frame_*.png"))
    code, stdout, err = invoke("identify", "--track", "--format", "json", *frames)
    assert code == 0, err
    records = _records(stdout)
    assert [r["mode"] for r in records] == ["lost_in_space"] + ["tracking"] * 3
    truth = pd.read_csv(out / "stars.csv", dtype={"catalog_id": str})
    for k, r in enumerate(records):
        stars = truth[truth.frame == k]
        for star in r["stars"]:
            d2 = (stars.x - star["x"]) ** 2 + (stars.y - star["y"]) ** 2
            nearest = stars.iloc[int(np.argmin(d2.to_numpy()))]
            assert d2.min() < 9.0 and not nearest.is_false
            assert nearest.catalog_id == str(star["catalog_id"])
