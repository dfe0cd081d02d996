"""Issue 31: every output of every command aimed at its inputs, an input's sidecar, a
symlink, a FIFO and a device node is refused with one line (exit 2), and every input is
byte-identical afterwards; compare and simulate folders: one lock, one run identity, and
only their own listed files touched."""

from __future__ import annotations

import contextlib
import json
import os
import select
import stat
import threading
from pathlib import Path

import pytest

from tests.cli.test_reliability import CAMERA, cli, one_error

COMPARE = ["compare", "--methods", "angle", "--frames", "2", "--noise-px", "0",
           "--false-stars", "0", "--jobs", "1"]
TRACKING = ["compare", "--mode", "tracking", "--frames", "2", "--rates", "1",
            "--noise-px", "0", "--false-stars", "0", "--missing", "0"]


@pytest.fixture(scope="module")
def frames(tmp_path_factory) -> Path:
    """Two simulated 256 x 256 frames with their sidecars, and the camera file."""
    root = tmp_path_factory.mktemp("targets")
    (root / "cam.json").write_text(json.dumps(CAMERA))
    assert cli("simulate", "--camera", root / "cam.json", "--frames", "2", "--out",
               root / "sim").returncode == 0
    return root


@contextlib.contextmanager
def _drained(fifo: Path):
    """A reader on ``fifo`` (opened non-blocking) that drains it while the command runs,
    so a command that wrongly opened it for writing could never block the test."""
    if not stat.S_ISFIFO(os.lstat(fifo).st_mode):
        yield
        return
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    stop = threading.Event()

    def drain() -> None:
        while not stop.is_set():
            data = b""
            if select.select([fd], [], [], 0.05)[0]:
                with contextlib.suppress(BlockingIOError):
                    data = os.read(fd, 1 << 16)
            if not data:  # no writer (end of file): wait rather than spin
                stop.wait(0.05)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    try:
        yield
    finally:
        stop.set()
        reader.join(5)
        os.close(fd)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def _target(kind: str, tmp: Path, sim: Path) -> Path:
    """A hostile output path of ``kind``; None when it cannot be made here."""
    if kind == "input":
        return sim / "frame_0000.png"
    if kind == "sidecar":
        return sim / "frame_0000.json"
    path = tmp / f"hostile_{kind}"
    if kind == "symlink":
        (tmp / "pointed_at").write_text("the user's file\n")
        path.symlink_to("pointed_at")
    elif kind == "fifo":
        os.mkfifo(path)  # refused before any open: nothing can block on it
    elif kind == "device":
        if os.geteuid() != 0:
            pytest.skip("a private device node needs root")
        os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 3))  # like /dev/null
    return path


COMMANDS = {
    "identify --output": lambda t, r: ["identify", r / "sim/frame_0000.png", "--output", t],
    "identify --annotate": lambda t, r: ["identify", r / "sim/frame_0000.png",
                                         "--annotate", t],
    "identify --wcs": lambda t, r: ["identify", r / "sim/frame_0000.png", "--wcs", t],
    "identify --corr": lambda t, r: ["identify", r / "sim/frame_0000.png", "--corr", t],
    "calibrate --output": lambda t, r: ["calibrate", r / "sim/frame_0000.png", "--camera",
                                        r / "cam.json", "--output", t],
    "compare --out": lambda t, r: [*COMPARE, "--out", t],
    "compare --mode tracking --out": lambda t, r: [*TRACKING, "--out", t],
    "simulate --out": lambda t, r: ["simulate", "--camera", r / "cam.json", "--frames", "1",
                                    "--out", t],
}


@pytest.mark.parametrize("kind", ["input", "sidecar", "symlink", "fifo", "device"])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_output_on_a_hostile_target_is_refused(frames, tmp_path, command, kind):
    sim = frames / "sim"
    target = _target(kind, tmp_path, sim)
    before = _snapshot(sim), (frames / "cam.json").read_bytes()
    lstat_before = os.lstat(target)
    with _drained(target):
        result = cli(*COMMANDS[command](target, frames))
    line = one_error(result)
    assert str(target) in line and ".tmp" not in line
    assert (_snapshot(sim), (frames / "cam.json").read_bytes()) == before
    after = os.lstat(target)
    assert stat.S_IFMT(after.st_mode) == stat.S_IFMT(lstat_before.st_mode)
    assert after.st_ino == lstat_before.st_ino
    if kind == "symlink":
        assert (tmp_path / "pointed_at").read_text() == "the user's file\n"


@pytest.mark.parametrize("option", ["--annotate", "--wcs"])
def test_a_folder_output_never_overwrites_the_inputs_inside_it(frames, tmp_path, option):
    # Issue 31: --annotate naming the inputs' folder turned both 16-bit inputs into
    # 8-bit annotated images; the names written inside the folder are checked.
    sim = tmp_path / "t1"
    sim.mkdir()
    for name in ("frame_0000.png", "frame_0000.json", "frame_0001.png", "frame_0001.json"):
        (sim / name).write_bytes((frames / "sim" / name).read_bytes())
    before = _snapshot(sim)
    stray = sim / "frame_0000.wcs"
    stray.write_text("a wcs of the user's\n") if option == "--wcs" else None
    for args in ([sim / "frame_0000.png", sim / "frame_0001.png"], [sim / "frame_0000.png"]):
        result = cli("identify", *args, option, sim)
        assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
        assert "frame_0000" in result.stderr
        assert {k: v for k, v in _snapshot(sim).items() if k != "frame_0000.wcs"} == before
    if option == "--wcs":
        assert stray.read_text() == "a wcs of the user's\n"  # existing: --overwrite only


def test_an_existing_output_needs_overwrite(frames, tmp_path):
    png = frames / "sim" / "frame_0000.png"
    out = tmp_path / "answer.json"
    out.write_text("mine\n")
    one_error(cli("identify", png, "--format", "json", "--output", out), "--overwrite")
    assert out.read_text() == "mine\n"
    assert cli("identify", png, "--format", "json", "--output", out, "--overwrite") \
        .returncode == 0
    assert json.loads(out.read_text())["status"] == "solved"


# --- run folders --------------------------------------------------------------------------

def test_compare_on_a_users_folder_needs_overwrite_and_keeps_the_users_files(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    user = {"report.txt": b"notes\n", "plot_x.png": b"\x89PNG mine", ".env.defaults": b"A=1\n"}
    for name, data in user.items():
        (out / name).write_bytes(data)
    one_error(cli(*COMPARE, "--out", out), "did not write", "--overwrite")
    one_error(cli(*TRACKING, "--out", out), "did not write", "--overwrite")
    assert sorted(os.listdir(out)) == sorted(user)
    assert cli(*COMPARE, "--out", out, "--overwrite").returncode == 0
    assert cli(*COMPARE, "--out", out, "--overwrite", "--no-resume").returncode == 0
    for name, data in user.items():
        assert (out / name).read_bytes() == data
    assert (out / "summary.csv").is_file() and (out / "report.md").is_file()


def test_tracking_onto_a_finished_lost_in_space_run_is_refused(tmp_path):
    out = tmp_path / "cmp"
    assert cli(*COMPARE, "--out", out).returncode == 0
    before = _snapshot(out)
    one_error(cli(*TRACKING, "--out", out), "different comparison run", "mode")
    assert _snapshot(out) == before
    # started over on purpose: only the listed files of the earlier run are replaced
    (out / "plot_mine.png").write_bytes(b"mine")
    assert cli(*TRACKING, "--out", out, "--no-resume", "--overwrite").returncode == 0
    assert (out / "plot_mine.png").read_bytes() == b"mine"
    assert not (out / "db.csv").exists()  # the lost-in-space run's own file is gone
    assert json.loads((out / "run.json").read_text())["mode"] == "tracking"
    one_error(cli(*COMPARE, "--out", out, "--overwrite"), "different comparison run")


@pytest.mark.parametrize("holder", ["compare", "simulate"])
def test_a_second_run_of_any_mode_on_a_held_folder_is_refused(tmp_path, holder):
    from startrack.io import RunFolder

    out = tmp_path / "cmp"
    with RunFolder(out, holder):  # the first run, holding the lock
        for args in (COMPARE, TRACKING):
            one_error(cli(*args, "--out", out), f"another {holder}", ".lock")
        cam = tmp_path / "cam.json"
        cam.write_text(json.dumps(CAMERA))
        one_error(cli("simulate", "--camera", cam, "--frames", "1", "--out", out), ".lock")
    assert cli(*TRACKING, "--out", out).returncode == 0


def test_simulate_never_writes_onto_an_input_inside_its_folder(tmp_path):
    out = tmp_path / "sim"
    out.mkdir()
    cam = out / "frame_0000.json"  # the camera file, named as a sidecar would be
    cam.write_text(json.dumps(CAMERA))
    before = cam.read_bytes()
    one_error(cli("simulate", "--camera", cam, "--frames", "1", "--out", out, "--overwrite"),
              "input")
    assert cam.read_bytes() == before


def test_tracking_started_during_a_running_compare_is_refused(tmp_path):
    # Issue 31: started 8 s into a running compare on the same --out, --mode tracking
    # succeeded and the first run lost all its rows.
    from tests.bench.test_reliability_runs import _long_compare

    out = tmp_path / "cmp"
    first = _long_compare(out)  # returns once its workers run (it holds the lock)
    try:
        one_error(cli(*TRACKING, "--out", out), "another compare", ".lock")
        assert first.poll() is None and not (out / "summary.csv").exists()
    finally:
        first.kill()
        first.wait(60)
