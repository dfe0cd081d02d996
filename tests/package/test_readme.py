"""The README's shell examples, in the order given: each parses (fast), and, with
``-m slow``, all of them run one after the other in a fresh folder as on a new clone."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import click
import pytest
from repo_paths import ROOT

from startrack.cli import main

VENV_STARTRACK = ".venv/bin/startrack"


def readme_commands() -> list[list[str]]:
    """Every command of the README's ``sh`` blocks, in order, as argument lists (comments
    dropped, continued lines joined, globs left to the shell)."""
    text = (ROOT / "README.md").read_text()
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words:
                commands.append(words)
    return commands


def demo_command() -> list[str]:
    """What ``make demo`` runs after setting up the venv (the Makefile's demo recipe)."""
    recipe = (ROOT / "Makefile").read_text().split("\ndemo:", 1)[1].splitlines()[1:]
    runs = [line.strip() for line in recipe if line.strip().startswith("$(BIN)/")]
    words = shlex.split(runs[0])
    assert words[0] == "$(BIN)/startrack"
    return [VENV_STARTRACK, *words[1:]]


def _startrack_commands() -> list[list[str]]:
    """The README's commands as startrack commands: ``make demo`` stands for its recipe,
    ``make test`` (this test suite itself) is left out."""
    out = []
    for words in readme_commands():
        if words[:2] == ["make", "demo"]:
            out.append(demo_command())
        elif words[:2] != ["make", "test"]:
            out.append(words)
    return out


def test_every_readme_command_is_startrack_and_parses():
    commands = _startrack_commands()
    assert len(commands) >= 8
    for words in commands:
        assert words[0] == VENV_STARTRACK, words
        # click parses the options (names, types, choices, callbacks) without running
        parent = click.Context(main, info_name="startrack")
        command = main.get_command(parent, words[1])
        assert command is not None and not isinstance(command, click.Group), words
        command.make_context(words[1], list(words[2:]), parent=parent)


def test_every_readme_run_writes_its_own_out_folder():
    outs = []
    for words in _startrack_commands():
        if words[1] in ("simulate", "compare"):
            outs.append(words[words.index("--out") + 1] if "--out" in words else
                        f"out/{words[1]}")
    assert len(outs) == len(set(outs)), outs  # a rerun must not meet another's folder


@pytest.mark.slow
def test_readme_commands_run_in_order_on_a_fresh_folder(tmp_path):
    """As on a fresh clone: no out/, the repository's configs and test data."""
    for name in ("configs", "tests"):
        (tmp_path / name).symlink_to(ROOT / name)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    startrack = f"{shlex.quote(sys.executable)} -m startrack"
    for words in _startrack_commands():
        line = " ".join([startrack, *(w if "*" in w else shlex.quote(w) for w in words[1:])])
        run = subprocess.run(line, shell=True, cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=1800)
        assert run.returncode == 0, f"{shlex.join(words)}\n{run.stderr[-2000:]}"
