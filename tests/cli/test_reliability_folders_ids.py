"""Issue 48, files and identities: a run folder refuses another command's run and never
replaces a file startrack did not write, a killed run's temporaries go, errors name the
user's path; catalog ids stay exact 64-bit integers; a --frames-dir whose truth disagrees
with its own stars.csv is refused, never scored."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_reliability import CAMERA, cli, one_error
from waiting import CHILD_TIMEOUT_S, wait_for

from startrack.errors import InputError
from startrack.io._writer import OutputError, atomic_path
from startrack.sky import BadId, exact_ids
from startrack.sky._user_catalog import parse_catalog

COMPARE = ["compare", "--methods", "angle", "--frames", "2", "--noise-px", "0",
           "--false-stars", "0", "-q"]
TRACKING = ["compare", "--mode", "tracking", "--frames", "2", "--rates", "1",
            "--noise-px", "0", "--false-stars", "0", "--missing", "0", "-q"]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.name != ".lock"}


@pytest.fixture()
def cam(tmp_path) -> Path:
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(CAMERA))
    return path


@pytest.fixture()
def sim(tmp_path, cam) -> Path:
    out = tmp_path / "sim"
    assert cli("simulate", "--camera", cam, "--frames", "2", "--out", out, "-q").returncode == 0
    return out


# --- run folders --------------------------------------------------------------------------

def test_compare_onto_a_simulate_folder_is_refused_whatever_overwrite_says(sim, tmp_path):
    before = _snapshot(sim)
    for extra in ([], ["--overwrite"], ["--overwrite", "--no-resume"], ["--no-resume"]):
        for args in (COMPARE, TRACKING):
            one_error(cli(*args, *extra, "--out", sim), "simulate", "another command")
        one_error(cli("compare", "--frames-dir", sim, "--methods", "angle", "-q", *extra,
                      "--out", sim), "--out")
    other = tmp_path / "sim2"
    shutil.copytree(sim, other)
    one_error(cli("compare", "--frames-dir", sim, "--methods", "angle", "-q", "--overwrite",
                  "--out", other), "simulate", "another command")
    assert _snapshot(sim) == before and _snapshot(other) == before


def test_simulate_onto_a_compare_folder_is_refused_whatever_overwrite_says(cam, tmp_path):
    out = tmp_path / "cmp"
    assert cli(*COMPARE, "--out", out).returncode == 0
    before = _snapshot(out)
    for extra in ([], ["--overwrite"]):
        one_error(cli("simulate", "--camera", cam, "--frames", "1", "--out", out, *extra),
                  "compare", "another command")
    assert _snapshot(out) == before


@pytest.mark.parametrize("args, name", [
    (["simulate", "--camera", "{cam}", "--frames", "1"], "truth.csv"),
    (["simulate", "--camera", "{cam}", "--frames", "1"], "frame_0000.png"),
    (COMPARE, "summary.csv"),
    (COMPARE, "report.md"),
    (TRACKING, "frames.csv"),
])
def test_overwrite_never_replaces_a_users_file_with_startracks_name(cam, tmp_path, args,
                                                                    name):
    out = tmp_path / "mine"
    out.mkdir()
    (out / name).write_bytes(b"the user's own\n")
    args = [str(cam) if a == "{cam}" else a for a in args]
    one_error(cli(*args, "--out", out, "--overwrite"), name, "did not write")
    assert (out / name).read_bytes() == b"the user's own\n"
    assert sorted(os.listdir(out)) == [name]


def test_a_killed_simulates_temporaries_are_removed_by_the_next_run(cam, tmp_path):
    out = tmp_path / "sim"
    p = subprocess.Popen([sys.executable, "-m", "startrack", "simulate", "--camera", str(cam),
                          "--frames", "100000", "--out", str(out), "-q"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: (out / "frame_0002.png").exists() or p.poll() is not None)
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait(CHILD_TIMEOUT_S)
    stale = [n for n in os.listdir(out) if n.startswith((".truth.csv.", ".stars.csv."))]
    assert len(stale) == 2  # SIGKILL runs no clean-up: truth.csv, stars.csv never appeared
    assert not (out / "truth.csv").exists()
    assert cli("simulate", "--camera", cam, "--frames", "1", "--out", out,
               "--overwrite").returncode == 0
    assert sorted(os.listdir(out)) == [".lock", ".startrack-files", "frame_0000.json",
                                       "frame_0000.png", "stars.csv", "truth.csv"]


@pytest.mark.parametrize("error", [
    lambda tmp: RuntimeError(f"libpng error: Write Error on {tmp}"),
    lambda tmp: OSError(f"[Errno 28] No space left on device: '{tmp}'"),
])
def test_a_failed_write_names_the_users_path_never_the_temporary(tmp_path, error):
    target = tmp_path / "annotated.png"
    with pytest.raises(OutputError) as err, atomic_path(target, "--annotate") as tmp:
        raise error(tmp)
    message = str(err.value)
    assert str(target) in message and ".annotated.png." not in message
    assert os.listdir(tmp_path) == []


# --- identities ---------------------------------------------------------------------------

GAIA_BASE = 4_295_806_720_000_000_000  # above 2**61: float64 cannot hold these exactly


def test_ids_are_exact_64_bit_integers_whatever_the_column_holds():
    big = np.array([GAIA_BASE, GAIA_BASE + 1, 2**63 - 1], dtype=np.int64)
    assert exact_ids(big).tolist() == big.tolist()
    assert exact_ids(big.astype(str).astype(object)).tolist() == big.tolist()
    assert exact_ids(np.array([" 7 ", "8.0"], dtype=object)).tolist() == [7, 8]
    assert exact_ids(np.array([3, 4], dtype=np.uint64)).dtype == np.int64
    for bad, row, words in (
            (np.array(["1", "abc"], dtype=object), 1, "'abc' is not an integer"),
            (np.array(["99999999999999999999999"], dtype=object), 0, "beyond 64-bit"),
            (np.array([2.0**62]), 0, "float column"),
            (np.array([1.5]), 0, "not an integer"),
            (np.array([2**63], dtype=np.uint64), 0, "beyond 64-bit")):
        with pytest.raises(BadId) as err:
            exact_ids(bad)
        assert err.value.row == row and words in str(err.value)


def test_ids_differing_by_one_are_not_repeats(tmp_path):
    path = tmp_path / "cat.csv"
    path.write_text(f"id,ra,dec,mag\n{GAIA_BASE},1,2,3\n{GAIA_BASE + 1},1.1,2,3\n")
    assert parse_catalog(path)["ids"].tolist() == [GAIA_BASE, GAIA_BASE + 1]
    path.write_text(f"id,ra,dec,mag\n{GAIA_BASE},1,2,3\n{GAIA_BASE},1.1,2,3\n")
    with pytest.raises(InputError, match=f"row 2: id {GAIA_BASE} repeats"):
        parse_catalog(path)


def _gaia_patch(path: Path, n: int = 3000, seed: int = 4) -> np.ndarray:
    """A 3 x 3 deg patch about (150, 20) whose ids are consecutive Gaia-sized integers."""
    rng = np.random.default_rng(seed)
    ids = GAIA_BASE + np.arange(n, dtype=np.int64)
    table = pd.DataFrame({"source_id": ids,
                          "ra": 150.0 + rng.uniform(-1.5, 1.5, n) / np.cos(np.radians(20.0)),
                          "dec": 20.0 + rng.uniform(-1.5, 1.5, n),
                          "mag": 12.0 - rng.exponential(1.2, n).clip(0, 6)})
    table = table.rename(columns={"source_id": "id"})
    if path.suffix == ".parquet":
        table.to_parquet(path)
    else:
        table.to_csv(path, index=False, float_format="%.8f")
    return ids


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_gaia_id_catalogs_identities_are_exact(tmp_path, suffix):
    if suffix == ".parquet":
        pytest.importorskip("pyarrow")
    catalog = tmp_path / f"gaia{suffix}"
    ids = set(_gaia_patch(catalog).tolist())
    (tmp_path / "cam.json").write_text('{"width": 640, "height": 512, "fov_deg": 1.0}')
    assert cli("simulate", "--config", "narrow_gaia", "--camera", tmp_path / "cam.json",
               "--sky", catalog, "--mag-limit", "12", "--attitude", "150.2,19.8,30",
               "--frames", "1", "--out", tmp_path / "out", "-q").returncode == 0
    drawn = pd.read_csv(tmp_path / "out" / "stars.csv", dtype={"catalog_id": str})
    real = drawn[drawn["is_false"] == 0]["catalog_id"].map(int)
    assert len(real) >= 6 and set(real) <= ids
    done = cli("identify", tmp_path / "out" / "frame_0000.png", "--format", "json")
    record = json.loads(done.stdout)
    assert record["status"] == "solved"
    reported = [s["catalog_id"] for s in record["stars"]]
    assert len(reported) >= 6 and set(reported) <= set(real)  # each one the drawn star's


# --- --frames-dir truth -------------------------------------------------------------------

@pytest.fixture(scope="module")
def truth_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fd") / "sim"
    assert cli("simulate", "--frames", "3", "--out", out, "-q").returncode == 0
    for name in (".lock", ".startrack-files"):
        (out / name).unlink()
    return out


def _lines(folder: Path, name: str, edit) -> None:
    path = folder / name
    path.write_text("\n".join(edit(path.read_text().splitlines())) + "\n")


def _cell(line: str, index: int, value: str) -> str:
    cells = line.split(",")
    cells[index] = value
    return ",".join(cells)


def _shift_attitudes(folder: Path) -> None:
    truth = pd.read_csv(folder / "truth.csv")
    columns = ["qw", "qx", "qy", "qz", "ra_deg", "dec_deg", "roll_deg"]
    truth[columns] = np.roll(truth[columns].to_numpy(), 1, axis=0)
    truth.to_csv(folder / "truth.csv", index=False)


def _sidecar(folder: Path, edit) -> None:
    path = folder / "frame_0000.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


BAD_TRUTH = {
    "attitudes shifted by a row": (_shift_attitudes, ["truth.csv and stars.csv disagree",
                                                      "frame 0"]),
    "bad is_false cell": (lambda d: _lines(d, "stars.csv", lambda t: [
        t[0], _cell(t[1], 6, "x"), *t[2:]]), ["stars.csv: line 2", "is_false 'x'"]),
    "header-only stars.csv": (lambda d: _lines(d, "stars.csv", lambda t: t[:1]),
                              ["stars.csv", "no star"]),
    "negative frame": (lambda d: _lines(d, "truth.csv", lambda t: [
        t[0], _cell(t[1], 0, "-1"), *t[2:]]), ["truth.csv: line 2", "frame '-1'"]),
    "fractional frame": (lambda d: _lines(d, "truth.csv", lambda t: [
        t[0], _cell(t[1], 0, "0.5"), *t[2:]]), ["truth.csv: line 2", "frame '0.5'"]),
    "duplicated truth row": (lambda d: _lines(d, "truth.csv", lambda t: [*t, t[1]]),
                             ["truth.csv: line 5", "listed twice"]),
    "duplicated star row": (lambda d: _lines(d, "stars.csv", lambda t: [*t, t[1]]),
                            ["stars.csv", "repeats an earlier row"]),
    "zero quaternion": (lambda d: _lines(d, "truth.csv", lambda t: [
        t[0], _cell(_cell(t[1], 2, "0"), 3, "0"), *t[2:]]), ["truth.csv: line 2",
                                                            "has length 0"]),
    "1e300 quaternion": (lambda d: _lines(d, "truth.csv", lambda t: [
        t[0], _cell(t[1], 2, "1e300"), *t[2:]]), ["truth.csv: line 2", "has length inf"]),
    "catalog_id abc": (lambda d: _lines(d, "stars.csv", lambda t: [
        t[0], _cell(_cell(t[1], 5, "abc"), 6, "0"), *t[2:]]), ["line 2", "'abc'"]),
    "catalog_id past 64 bits": (lambda d: _lines(d, "stars.csv", lambda t: [
        t[0], _cell(_cell(t[1], 5, "99999999999999999999999"), 6, "0"), *t[2:]]),
        ["line 2", "beyond 64-bit"]),
    "sidecar false_stars many": (lambda d: _sidecar(d, lambda j: j["frames"].update(
        false_stars="many")), ["frame_0000.json", "false_stars", "'many'"]),
    "sidecar 1e300 quaternion": (lambda d: _sidecar(d, lambda j: j["attitude"].update(
        quaternion=[1e300, 0, 0, 0])), ["frame_0000.json", "quaternion"]),
}


@pytest.mark.parametrize("case", sorted(BAD_TRUTH))
def test_a_frames_dir_whose_truth_disagrees_is_refused_never_scored(truth_folder, tmp_path,
                                                                    case):
    edit, words = BAD_TRUTH[case]
    folder = tmp_path / "frames"
    shutil.copytree(truth_folder, folder)
    edit(folder)
    out = tmp_path / "out"
    one_error(cli("compare", "--frames-dir", folder, "--methods", "angle", "-q", "--out",
                  out), *words)
    assert not out.exists()


def test_a_catalog_reordered_after_simulate_is_refused(tmp_path):
    catalog = tmp_path / "patch.csv"
    _gaia_patch(catalog)
    table = pd.read_csv(catalog).drop(columns="id")  # ids: the row numbers
    table.to_csv(catalog, index=False, float_format="%.8f")
    (tmp_path / "cam.json").write_text('{"width": 640, "height": 512, "fov_deg": 1.0}')
    folder = tmp_path / "sim"
    assert cli("simulate", "--config", "narrow_gaia", "--camera", tmp_path / "cam.json",
               "--sky", catalog, "--mag-limit", "12", "--frames", "2", "--attitude",
               "150.2,19.8,30", "--out", folder, "-q").returncode == 0
    assert cli("compare", "--frames-dir", folder, "--methods", "pyramid", "-q", "--out",
               tmp_path / "good").returncode == 0
    table.sample(frac=1.0, random_state=1).to_csv(catalog, index=False, float_format="%.8f")
    one_error(cli("compare", "--frames-dir", folder, "--methods", "pyramid", "-q", "--out",
                  tmp_path / "bad"), "disagree")
