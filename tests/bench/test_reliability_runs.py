"""Issue 10, the runs: compare's lock, its workers after SIGKILL and SIGTERM, --jobs 2 ==
--jobs 1; simulate's output folder and limits; the cache's checksums, cap and command."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from waiting import CHILD_TIMEOUT_S, wait_for

from startrack.bench._runner import COLUMNS, TIMING_COLUMNS
from startrack.bench._store import read_done
from tests.cli.test_reliability import CAMERA, cli, one_error

RUN = ["compare", "--methods", "angle", "--noise-px", "0", "--false-stars", "0,2",
       "--seed", "3"]


def _alive_children(pid: int) -> list[int]:
    """Live (not zombie) processes whose parent is ``pid``, from /proc."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0] \
            != "Z"
    except OSError:
        return False


def _long_compare(out: Path) -> subprocess.Popen:
    """A compare that would run for hours, on two workers; returns once they are up."""
    p = subprocess.Popen([sys.executable, "-m", "startrack", *RUN, "--frames", "100000",
                          "--jobs", "2", "--out", str(out)], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    wait_for(lambda: len(_alive_children(p.pid)) >= 2 or p.poll() is not None)
    assert p.poll() is None, p.stderr.read()
    return p


def _numbers(units: dict) -> dict:
    keep = [i for i, c in enumerate(COLUMNS) if c not in TIMING_COLUMNS]
    return {u: [[row[i] for i in keep] for row in rows] for u, rows in units.items()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """16 frames per condition on one process: the numbers any other run must repeat."""
    out = tmp_path_factory.mktemp("ref") / "ref"
    assert cli(*RUN, "--frames", "16", "--jobs", "1", "--out", out).returncode == 0
    return _numbers(read_done(out / "frames.csv", COLUMNS, ["angle"]))


def test_jobs_2_equals_jobs_1(reference, tmp_path):
    assert cli(*RUN, "--frames", "16", "--jobs", "2", "--out", tmp_path).returncode == 0
    assert _numbers(read_done(tmp_path / "frames.csv", COLUMNS, ["angle"])) == reference


def test_second_run_on_one_out_is_refused_and_sigkill_leaves_no_workers(tmp_path):
    out = tmp_path / "cmp"
    p = _long_compare(out)
    try:
        second = cli(*RUN, "--frames", "100000", "--jobs", "1", "--out", out)
        one_error(second, "another compare", str(out / ".lock"))
        workers = _alive_children(p.pid)
    finally:
        p.kill()
        p.wait(CHILD_TIMEOUT_S)
    wait_for(lambda: not any(_alive(w) for w in workers))


def test_sigterm_stops_cleanly_and_what_was_done_is_right(reference, tmp_path):
    out = tmp_path / "cmp"
    p = _long_compare(out)
    wait_for(lambda: len(read_done(out / "frames.csv", COLUMNS, ["angle"])) >= 16)
    workers = _alive_children(p.pid)
    p.send_signal(signal.SIGTERM)
    assert p.wait(CHILD_TIMEOUT_S) == 143
    err = p.stderr.read()
    assert "Traceback" not in err and err.strip().splitlines()[-1].endswith(
        "nothing half-written was left")
    wait_for(lambda: not any(_alive(w) for w in workers))
    assert sorted(q.name for q in out.iterdir() if q.name.startswith(".")) == [
        ".lock", ".startrack-files"]  # the lock and the manifest; no temporary file
    done = _numbers(read_done(out / "frames.csv", COLUMNS, ["angle"]))
    shared = set(done) & set(reference)
    assert shared and all(done[u] == reference[u] for u in shared)


def test_compare_out_under_a_file_and_a_huge_sky_are_one_line(tmp_path):
    (tmp_path / "file").write_text("x")
    one_error(cli(*RUN, "--frames", "2", "--out", tmp_path / "file" / "out"), "file")
    result = cli(*RUN, "--frames", "2", "--sky", "hipparcos", "--mag-limit", "20",
                 "--out", tmp_path / "o")
    one_error(result, "--mag-limit", "STARTRACK_MAX_PAIRS")
    one_error(cli(*RUN, "--frames", "100000000", "--out", tmp_path / "o"), "--frames",
              "200,000,000 units")
    assert not (tmp_path / "o").exists()


# --- simulate ----------------------------------------------------------------------------

@pytest.fixture()
def cam(tmp_path) -> Path:
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(CAMERA))
    return path


def test_simulate_refuses_a_used_folder_and_overwrite_leaves_no_stale_frames(cam, tmp_path):
    out = tmp_path / "sim"
    assert cli("simulate", "--camera", cam, "--frames", "3", "--out", out).returncode == 0
    before = (out / "frame_0002.png").read_bytes()
    one_error(cli("simulate", "--camera", cam, "--frames", "1", "--out", out), "--overwrite")
    assert (out / "frame_0002.png").read_bytes() == before
    (out / "notes.txt").write_text("mine")
    assert cli("simulate", "--camera", cam, "--frames", "1", "--out", out, "--overwrite") \
        .returncode == 0
    assert sorted(p.name for p in out.iterdir()) == [
        ".lock", ".startrack-files", "frame_0000.json", "frame_0000.png", "notes.txt",
        "stars.csv", "truth.csv"]
    for name in ("stars.csv", "truth.csv"):
        assert b"\r" not in (out / name).read_bytes()


@pytest.mark.parametrize("args, words", [
    (["--mag-limit", "-5"], ["--mag-limit"]),
    (["--sky", "hipparcos", "--mag-limit", "-5"], ["--mag-limit"]),
    (["--camera", "{huge}"], ["100000 x 100000", "STARTRACK_MAX_IMAGE_PIXELS"]),
])
def test_simulate_limits_are_one_line_and_write_nothing(tmp_path, args, words):
    huge = tmp_path / "huge.json"
    huge.write_text('{"width": 100000, "height": 100000, "fov_deg": 10}')
    out = tmp_path / "out"
    one_error(cli("simulate", *[a.format(huge=huge) for a in args], "--out", out), *words)
    assert not out.exists()


# --- the cache ---------------------------------------------------------------------------

@pytest.fixture()
def hip_frame(cam, tmp_path):
    """A Hipparcos frame, its cache in tmp_path/cache, and the HIP ids it solves to."""
    env = {"STARTRACK_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "sim"
    assert cli("simulate", "--camera", cam, "--sky", "hipparcos", "--frames", "1",
               "--seed", "4", "--out", out, env=env).returncode == 0
    frame = out / "frame_0000.png"
    first = cli("identify", frame, "--format", "json", env=env)
    assert first.returncode == 0
    ids = [s["catalog_id"] for s in json.loads(first.stdout)["stars"]]
    assert len(ids) >= 5
    return frame, env, tmp_path / "cache", ids


def _alter(path: Path, change) -> None:
    """Rewrite a cache entry with its arrays changed but its stored checksum kept."""
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    np.savez(path, **change(arrays))


def test_altered_cache_contents_are_rebuilt_not_trusted(hip_frame):
    frame, env, cache, ids = hip_frame
    (hip,) = cache.glob("hipparcos-*.npz")
    _alter(hip, lambda a: {**a, "ids": np.roll(a["ids"], 1)})  # every HIP number off by one
    for pairs in cache.glob("pairs-*.npz"):
        _alter(pairs, lambda a: {"unexpected": np.arange(3)})
    again = cli("identify", frame, "--format", "json", env=env)
    assert again.returncode == 0 and again.stderr == ""
    assert [s["catalog_id"] for s in json.loads(again.stdout)["stars"]] == ids


def test_cache_info_clear_and_modes(hip_frame):
    _, env, cache, _ = hip_frame
    entries = sorted(p for p in cache.iterdir() if not p.name.startswith("."))
    assert entries and all(stat.S_IMODE(p.stat().st_mode) == 0o666 & ~_umask()
                           for p in entries)
    info = cli("cache", "info", env=env)
    assert info.returncode == 0 and str(cache) in info.stdout
    assert f"entries: {len(entries)}" in info.stdout
    cleared = cli("cache", "clear", env=env)
    assert cleared.returncode == 0 and f"removed {len(entries)} entries" in cleared.stdout
    assert list(cache.iterdir()) == []


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_the_cache_is_capped_least_recently_used_first(tmp_path, monkeypatch):
    from startrack.io import cache_entries, cached_arrays

    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("STARTRACK_CACHE_MAX_MB", "2.5")  # room for two 1 MB entries

    def build(k):
        return lambda: {"a": np.full(1024 * 128, k, np.float64)}  # 1 MB

    for k in range(3):
        cached_arrays("t", {"k": k}, build(k))
        time.sleep(0.05)
    assert len(cache_entries()) == 2  # entry 0, the oldest, was evicted
    cached_arrays("t", {"k": 1}, build(-1))  # a hit: entry 1 is now the most recent
    time.sleep(0.05)
    assert cached_arrays("t", {"k": 1}, build(-1))["a"][0] == 1  # from the cache
    cached_arrays("t", {"k": 3}, build(3))
    names = {p.name for p, _, _ in cache_entries()}
    from startrack.io._cache import cache_key

    assert names == {f"{cache_key('t', {'k': k})}.npz" for k in (1, 3)}


def test_sigterm_during_identify_leaves_no_output(tmp_path):
    csv_path = tmp_path / "f.csv"
    csv_path.write_text("x,y\n" + "".join(f"{10 + 7 * k},{20 + 5 * k}\n" for k in range(30)))
    out = tmp_path / "o" / "out.jsonl"
    p = subprocess.Popen([sys.executable, "-m", "startrack", "identify", *[str(csv_path)] * 5000,
                          "--fov", "17.5", "--size", "256x256", "--sky", "random",
                          "--format", "json", "--output", str(out)],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    # SIGTERM once the first record is in the temporary output: the child is then in its
    # loop over the inputs (kernels compiled, nothing left to wait for but the signal).
    wait_for(lambda: _written(out.parent) or p.poll() is not None)
    assert p.poll() is None, p.stderr.read()
    p.send_signal(signal.SIGTERM)
    assert p.wait(CHILD_TIMEOUT_S) == 143, p.stderr.read()
    assert "Traceback" not in p.stderr.read()
    assert list(out.parent.iterdir()) == []


def _written(folder: Path) -> bool:
    """Whether a file in ``folder`` holds something (a temporary output being written)."""
    try:
        return any(f.stat().st_size > 0 for f in folder.iterdir())
    except OSError:  # not made yet, or the file was just renamed or removed
        return False
