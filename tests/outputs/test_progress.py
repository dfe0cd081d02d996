"""Progress lines when stderr is not a terminal, and -q/-v on every command."""

import io

import pytest
from click.testing import CliRunner

from startrack.cli import main
from startrack.outputs._progress import LineProgress


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_a_line_every_few_seconds_and_one_at_the_end():
    clock, out = Clock(), io.StringIO()
    bar = LineProgress(100, desc="compare", unit="frame", every=10.0, stream=out, clock=clock)
    for _ in range(40):  # 40 frames in 4 s: no line yet
        clock.t += 0.1
        bar.update(1)
    assert out.getvalue() == ""
    for _ in range(60):
        clock.t += 0.5
        bar.update(1)
    bar.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 4  # at 10, 20 and 30 s, and the end
    assert lines[0].startswith("compare: ") and "frame" in lines[0] and "left" in lines[0]
    assert lines[-1].startswith("compare: 100/100 frame (100%)")


def test_a_short_run_prints_nothing():
    out = io.StringIO()
    bar = LineProgress(5, desc="x", stream=out, clock=Clock())
    bar.update(5)
    bar.close()
    assert out.getvalue() == ""


@pytest.mark.parametrize("command", [["simulate"], ["identify"], ["compare"], ["calibrate"],
                                     ["cache", "info"], ["cache", "clear"]])
def test_every_command_takes_quiet_and_verbose(command):
    text = CliRunner().invoke(main, [*command, "--help"]).output
    assert "-q, --quiet" in text and "-v, --verbose" in text


def test_compare_help_ends_in_a_sentence_not_a_stray_path():
    text = CliRunner().invoke(main, ["compare", "--help"]).output
    description = text.split("Options:")[0].strip()
    assert description.endswith(".") and not description.endswith("docs/conventions.md.")
    assert "docs/conventions.md" in description


def test_simulate_quiet_and_verbose(tmp_path):
    args = ["simulate", "--frames", "2", "--out"]
    quiet = CliRunner().invoke(main, [*args, str(tmp_path / "q"), "-q"])
    assert quiet.exit_code == 0 and quiet.stderr == ""
    loud = CliRunner().invoke(main, [*args, str(tmp_path / "v"), "-v"])
    assert loud.exit_code == 0
    assert [line.split(":")[0] for line in loud.stderr.splitlines()] == [
        "frame_0000.png", "frame_0001.png"]


def test_compare_quiet_and_verbose(tmp_path):
    args = ["compare", "--frames", "3", "--methods", "pyramid", "--noise-px", "0,1",
            "--false-stars", "0", "--jobs", "1", "--out"]
    quiet = CliRunner().invoke(main, [*args, str(tmp_path / "q"), "-q"])
    assert quiet.exit_code == 0, quiet.output
    assert quiet.stderr == "" and "pyramid" in quiet.stdout
    loud = CliRunner().invoke(main, [*args, str(tmp_path / "v"), "-v"])
    assert loud.exit_code == 0, loud.output
    lines = loud.stderr.splitlines()
    assert lines[0].startswith("compare: pyramid on 2 condition(s)")
    assert [line.split(":")[0].strip() for line in lines[1:3]] == ["condition 0",
                                                                  "condition 1"]
