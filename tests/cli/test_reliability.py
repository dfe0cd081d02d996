"""Hostile inputs and outputs (issue 10): each ends as one stderr line and exit 2, or as the
right answer, and the output paths are left as they were (or whole)."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from waiting import CHILD_TIMEOUT_S

from startrack.cli import main

CAMERA = {"width": 256, "height": 256, "fov_deg": 17.5}


def cli(*args, env: dict | None = None) -> subprocess.CompletedProcess:
    """The command in this process (click's runner): exit code, stdout, stderr."""
    result = CliRunner(env=env).invoke(main, [str(a) for a in args], catch_exceptions=False)
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.stderr)


def proc(*args, **kw) -> subprocess.CompletedProcess:
    """The command as its own process (for the process-level cases)."""
    kw.setdefault("capture_output", "stdout" not in kw)
    return subprocess.run([sys.executable, "-m", "startrack", *map(str, args)], text=True,
                          timeout=CHILD_TIMEOUT_S, **kw)


def one_error(result, *words: str, code: int = 2) -> str:
    """Exit ``code`` and exactly one stderr line, without a traceback, holding ``words``."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == code, (result.returncode, result.stderr)
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def no_temporaries(folder: Path) -> None:
    assert [p.name for p in folder.iterdir() if p.name.startswith(".")] == []


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    """Two simulated 256 x 256 frames of the default random sky, and a centroid CSV."""
    root = tmp_path_factory.mktemp("rel")
    cam = root / "cam.json"
    cam.write_text(json.dumps(CAMERA))
    assert cli("simulate", "--camera", cam, "--frames", "2", "--out", root / "sim").returncode == 0
    rows = np.genfromtxt(root / "sim" / "stars.csv", delimiter=",", names=True)
    first = rows[(rows["frame"] == 0) & (rows["is_false"] == 0)]
    csv_path = root / "frame0.csv"
    csv_path.write_text("x,y,flux\n" + "".join(f"{r['x']},{r['y']},{r['flux']}\n"
                                               for r in first))
    return root, cam, root / "sim" / "frame_0000.png", csv_path


def test_the_frames_solve(sim):
    root, cam, png, csv_path = sim
    assert cli("identify", png).returncode == 0
    result = cli("identify", csv_path, "--camera", cam, "--sky", "random", "--format", "json")
    assert result.returncode == 0 and json.loads(result.stdout)["status"] == "solved"


# --- outputs: devices, symlinks, inputs, write errors -----------------------------------

def test_output_to_a_device_is_refused_and_stays_a_device(sim):
    # docs/conventions.md: startrack writes regular files only (never through a device)
    _, _, png, _ = sim
    one_error(cli("identify", png, "--output", "/dev/full"), "/dev/full", "not a regular file")
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_output_symlink_is_refused_and_stays_a_link(sim, tmp_path):
    _, _, png, _ = sim
    link, target = tmp_path / "link.jsonl", tmp_path / "target.jsonl"
    link.symlink_to(target.name)
    one_error(cli("identify", png, "--format", "json", "--output", link), str(link),
              "symlink")
    assert link.is_symlink() and os.readlink(link) == target.name and not target.exists()
    no_temporaries(tmp_path)


def test_output_fifo_is_refused_without_opening_it(sim, tmp_path):
    _, _, png, _ = sim
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)  # refused before it is opened: nothing can block on it
    one_error(cli("identify", png, "--format", "json", "--output", fifo), str(fifo),
              "not a regular file")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


@pytest.mark.parametrize("how", ["same", "symlink", "hardlink", "sidecar"])
def test_output_that_is_an_input_is_refused(sim, tmp_path, how):
    _, cam, _, frame_csv = sim
    csv_path = tmp_path / "in.csv"
    csv_path.write_bytes(frame_csv.read_bytes())
    out = {"same": csv_path, "symlink": tmp_path / "s.csv", "hardlink": tmp_path / "h.csv",
           "sidecar": tmp_path / "in.json"}[how]
    if how == "symlink":
        out.symlink_to(csv_path)
    elif how == "hardlink":
        os.link(csv_path, out)
    elif how == "sidecar":
        out.write_text("{}")
    before = {p: p.read_bytes() for p in (csv_path, out)}
    for option in ("--output", "--corr"):
        result = cli("identify", csv_path, "--camera", cam, "--sky", "random", option, out)
        one_error(result, option, "refusing to overwrite an input")
    assert {p: p.read_bytes() for p in (csv_path, out)} == before


def test_output_under_a_file_is_one_line(sim, tmp_path):
    _, _, png, _ = sim
    (tmp_path / "file").write_text("x")
    one_error(cli("identify", png, "--output", tmp_path / "file" / "out.json"),
              "parent folder is a file")
    assert (tmp_path / "file").read_text() == "x"


def test_stdout_on_a_full_disk_is_one_line(sim):
    _, _, png, _ = sim
    with open("/dev/full", "w") as full:
        result = proc("identify", png, stdout=full, stderr=subprocess.PIPE)
    one_error(result, "standard output", "No space left")


@pytest.mark.parametrize("args", [["--help"], ["cache", "info"],
                                  ["simulate", "--camera", "{cam}", "--frames", "1",
                                   "--out", "{tmp}/sim"]])
def test_every_command_on_a_full_stdout_is_one_line(sim, tmp_path, args):
    _, cam, _, _ = sim
    with open("/dev/full", "w") as full:
        result = proc(*[a.format(cam=cam, tmp=tmp_path) for a in args], stdout=full,
                      stderr=subprocess.PIPE)
    one_error(result, "standard output", "No space left")


@pytest.mark.parametrize("args", [["cache", "info"], ["--help"]])
def test_any_command_on_a_closed_pipe_is_quiet(args):
    p = subprocess.Popen([sys.executable, "-m", "startrack", *args], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    p.stdout.close()
    err = p.stderr.read()
    assert p.wait(60) == 2 and err == ""


def test_a_closed_pipe_ends_quietly(sim):
    _, _, png, _ = sim
    p = subprocess.Popen([sys.executable, "-m", "startrack", "identify", str(png), str(png),
                          "--format", "csv"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    p.stdout.close()  # the reader is gone before anything is written (`| head -0`)
    err = p.stderr.read()
    assert p.wait(120) == 2 and err == ""


def test_outputs_follow_the_umask_and_csv_is_lf(sim, tmp_path):
    _, _, png, _ = sim
    old = os.umask(0o027)
    try:
        assert cli("identify", png, "--format", "csv", "--output", tmp_path / "o.csv") \
            .returncode == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "o.csv").st_mode) == 0o640
    assert b"\r" not in (tmp_path / "o.csv").read_bytes()


# --- camera files and options ------------------------------------------------------------

BAD_CAMERAS = [
    ('{"width": 1e400, "height": 256, "fov_deg": 10}', "width"),
    ('{"width": 1' + "0" * 400 + ', "height": 256, "fov_deg": 10}', "width"),
    ('{"width": "256", "height": 256, "fov_deg": 10}', "width"),
    ('{"width": true, "height": 256, "fov_deg": 10}', "width"),
    ('{"width": 256.5, "height": 256, "fov_deg": 10}', "width"),
    ('{"width": 256, "height": 256, "fov_deg": NaN}', "fov_deg"),
    ('{"width": 256, "height": 256, "focal_length_mm": NaN, "pixel_size_um": 5}',
     "focal_length_mm"),
    ('{"width": 256, "height": 256, "focal_length_mm": 50, "pixel_size_um": Infinity}',
     "pixel_size_um"),
    ('{"width": 256, "height": 256, "focal_length_mm": 1e-9, "pixel_size_um": 5}',
     "focal_length_mm"),
    ('{"width": 256, "height": 256, "focal_length_mm": 0.01, "pixel_size_um": 500}',
     "field of view"),
    ('{"width": 256, "height": 256, "fov_deg": 17.5, "cx": 100000}', "cx"),
    ('{"width": 256, "height": 256, "fov_deg": 17.5, "cy": -40}', "cy"),
    ('{"width": 256, "height": 256, "fov_deg": 17.5, "lens": 3}', "unknown key"),
    ('{"width": 256, "fov_deg": 17.5}', "height"),
    ('{"width": 256, "height": 256, "fov_deg": 17.5', "not valid"),
    (b'\xff\xfe{"width": 256}', "not UTF-8"),
]


@pytest.mark.parametrize("text, word", BAD_CAMERAS)
def test_bad_camera_file_is_one_line_naming_it(sim, tmp_path, text, word):
    _, _, _, csv_path = sim
    cam = tmp_path / "bad.json"
    cam.write_bytes(text if isinstance(text, bytes) else text.encode())
    out = tmp_path / "out.json"
    one_error(cli("identify", csv_path, "--camera", cam, "--output", out), "bad.json", word)
    assert not out.exists()
    no_temporaries(tmp_path)


def test_fov_beside_camera_is_an_error(sim):
    _, cam, _, csv_path = sim
    one_error(cli("identify", csv_path, "--camera", cam, "--fov", "10"), "--camera", "--fov")


def test_fov_option_overrides_the_sidecar(sim, tmp_path):
    root, _, png, _ = sim
    frame = tmp_path / "f.png"
    frame.write_bytes(png.read_bytes())
    side = json.loads((root / "sim" / "frame_0000.json").read_text())
    side["camera"]["fov_deg"] = 12.0  # a wrong sidecar: the option must win
    (tmp_path / "f.json").write_text(json.dumps(side))
    result = cli("identify", frame, "--fov", "17.5", "--format", "json")
    record = json.loads(result.stdout)
    assert result.returncode == 0 and record["status"] == "solved"
    fov = record.get("fov_deg", record["diagnostics"]["camera"]["fov_deg"])
    assert abs(fov - 17.5) < 0.5  # the sidecar's 12 deg was not used


def test_an_unrelated_json_beside_an_input_is_not_a_sidecar(sim, tmp_path):
    _, _, png, _ = sim
    frame = tmp_path / "f.png"
    frame.write_bytes(png.read_bytes())
    (tmp_path / "f.json").write_text('{"camera": "my notes", "observer": "me"}')
    result = cli("identify", frame, "--fov", "17.5", "--sky", "random", "--format", "json")
    assert result.returncode == 0 and json.loads(result.stdout)["status"] == "solved"
    assert "not a startrack sidecar" in one_error(result, "f.json", code=0)


def _tmpfs(mnt: Path, options: str) -> None:
    """Mount a tmpfs (root only; the test is skipped where mounting is not allowed)."""
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")


@pytest.fixture()
def full_disk(tmp_path):
    """A 64 kB tmpfs, filled."""
    mnt = tmp_path / "full"
    _tmpfs(mnt, "size=64k")
    try:
        (mnt / "fill").write_bytes(b"\0" * 60_000)
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


@pytest.fixture()
def read_only(tmp_path):
    """A read-only folder that is read-only for root too (a read-only mount)."""
    mnt = tmp_path / "ro"
    _tmpfs(mnt, "ro,size=64k")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_a_read_only_folder_is_one_line(sim, read_only):
    _, cam, png, _ = sim
    one_error(cli("identify", png, "--output", read_only / "o.json"), "Read-only")
    from startrack.io._writer import OutputError, Writer

    with pytest.raises(OutputError) as err, Writer().text(read_only / "c.json", "--output"):
        pass  # calibrate --output's writer: its error names the user's path, not the temp's
    assert str(err.value).startswith(f"--output {read_only / 'c.json'}: cannot write")
    one_error(cli("simulate", "--camera", cam, "--out", read_only / "sim"), "Read-only")
    one_error(cli("compare", "--methods", "angle", "--frames", "2", "--noise-px", "0",
                  "--false-stars", "0", "--out", read_only / "cmp"), "Read-only")
    assert list(read_only.iterdir()) == []


def test_a_full_disk_is_one_line_and_leaves_nothing(sim, full_disk):
    _, cam, png, _ = sim
    one_error(cli("identify", png, png, "--format", "json", "--output", full_disk / "o.json"),
              "o.json", "No space left")
    one_error(cli("simulate", "--camera", cam, "--out", full_disk / "sim"), "cannot write")
    # the run's lock stays (docs/conventions.md); no output, whole or torn
    assert sorted(p.name for p in full_disk.rglob("*")) == [".lock", "fill", "sim"]
