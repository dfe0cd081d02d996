"""Options shared by the commands: parsers (click callbacks) and -q/-v."""

from __future__ import annotations

import math

import click


def triple(names: str):
    """A click callback parsing ``A,B,C`` into three finite floats (None stays None)."""
    def parse(ctx, param, value):
        if value is None:
            return None
        try:
            parts = tuple(float(p) for p in value.split(","))
        except ValueError:
            parts = ()
        if len(parts) != 3 or not all(math.isfinite(p) for p in parts):
            raise click.BadParameter(f"expected three numbers {names}, got {value!r}")
        return parts
    return parse


def verbosity(command):
    """``-q/--quiet`` and ``-v/--verbose``, the same on every command (docs/conventions.md):
    -q prints nothing on stderr but errors and warnings (no progress, no notes); -v adds a
    line per step or input. Results on stdout and written files are the same either way."""
    command = click.option("-v", "--verbose", is_flag=True,
                           help="A line on stderr per step or input.")(command)
    return click.option("-q", "--quiet", is_flag=True,
                        help="Nothing on stderr but errors and warnings.")(command)


def notes(quiet: bool, verbose: bool):
    """``(note, detail)``: print a note on stderr unless -q; a detail only with -v."""
    def note(text: str) -> None:
        if not quiet:
            click.echo(text, err=True)

    def detail(text: str) -> None:
        if verbose and not quiet:
            click.echo(text, err=True)
    return note, detail
