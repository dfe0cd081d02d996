"""How `startrack identify` writes its answers: records in a format, notes, progress."""

from __future__ import annotations

import contextlib
import csv
import json
import sys
from pathlib import Path

import click

#: a batch of at least this many inputs shows a progress bar (when stderr is a terminal)
PROGRESS_MIN_INPUTS = 3


def around_bar(emit):
    """``emit`` that lifts the progress bar off the terminal while it prints."""
    from tqdm import tqdm

    def emit_clear(record: dict) -> None:
        with tqdm.external_write_mode(file=sys.stdout):
            emit(record)
    return emit_clear


def verbose_notes(quiet: bool, verbose: bool):
    """A function printing a note on stderr when -v is given (never with -q); slow
    table builds are announced unless -q."""
    from startrack.io import announce_builds  # the cache's module loads numpy: on use

    announce_builds(not quiet)

    def note(text: str) -> None:
        if verbose and not quiet:
            click.echo(text, err=True)
    return note


#: the --fov-tolerance a "not solved" at a nominal FOV suggests: a wider search, still bounded
SUGGESTED_TOLERANCE = 0.4


def fov_suggestion(record: dict, fov_option: bool) -> str | None:
    """What to try when a nominal field of view found no match (None otherwise): a wider
    --fov-tolerance, naming the range it searches, and (when --fov gave it) no --fov."""
    request = record.get("requested") or {}
    fov, tol = request.get("fov_deg"), request.get("fov_tolerance")
    if record["status"] != "not_solved" or record.get("reason") != "no_match" \
            or fov is None or tol is None or tol >= SUGGESTED_TOLERANCE:
        return None
    lo, hi = fov * (1 - SUGGESTED_TOLERANCE), fov * (1 + SUGGESTED_TOLERANCE)
    text = (f"no match within {fov:g} deg +-{tol:.0%}; if the field of view may be further "
            f"off, try --fov-tolerance {SUGGESTED_TOLERANCE:g} (searches {lo:.2f} to "
            f"{hi:.2f} deg)")
    if fov_option:
        text += ", or leave out --fov (a blind search)"
    return text


def say_written(paths: list, quiet: bool, verbose: bool, output=None) -> None:
    """Name the files written on stderr: -v a line each; else one line for the side files
    (not ``output``, which was asked for by name): their count and folders when more than
    four; -q nothing."""
    if quiet or not paths:
        return
    if verbose:
        for path in paths:
            click.echo(f"wrote {path}", err=True)
        return
    paths = [p for p in paths if output is None or Path(p) != Path(output)]
    if not paths:
        return
    if len(paths) <= 4:
        click.echo("wrote " + ", ".join(str(p) for p in paths), err=True)
    else:
        folders = sorted({str(p.parent) for p in paths})
        click.echo(f"wrote {len(paths)} files in {', '.join(folders)}", err=True)


def summary_line(record: dict) -> str:
    n = len(record["stars"])
    ms = record["timing_ms"]["total"]
    what = f"solved, {n} stars" if record["status"] == "solved" else \
        f"not solved ({record.get('reason', 'no_match')})"
    return f"{record.get('input', '')}: {what}, {ms:.0f} ms"


def inputs_with_progress(inputs, quiet: bool, stack: contextlib.ExitStack):
    """The inputs, with a progress bar on stderr for a batch when stderr is a terminal, a
    line every few seconds when it is not (startrack.outputs._progress)."""
    if quiet or len(inputs) < PROGRESS_MIN_INPUTS:
        return inputs
    if not sys.stderr.isatty():
        from startrack.outputs import iterate

        return iterate(inputs, desc="identify", unit="input")
    from tqdm import tqdm

    return stack.enter_context(tqdm(inputs, file=sys.stderr, unit="input", desc="identify",
                                    leave=False, dynamic_ncols=True))


class NothingAnswered(Exception):
    """Every input was bad: the atomic output is discarded rather than written."""


def record_writer(fh, fmt: str, several: bool):
    """A function writing one record to ``fh`` in ``fmt`` (the CSV header first)."""
    from startrack.outputs import CSV_HEADER, csv_rows, format_table  # as in identify()

    writer = csv.writer(fh, lineterminator="\n") if fmt == "csv" else None
    if writer is not None:
        writer.writerow(CSV_HEADER)

    def emit(record: dict) -> None:
        if fmt == "json":
            fh.write(json.dumps(record) + "\n")
        elif writer is not None:
            writer.writerows(csv_rows(record))
        else:
            fh.write(format_table(record) + ("\n" if several else ""))
        fh.flush()

    return emit
