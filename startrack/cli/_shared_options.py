"""Options shared by the commands: parsers (click callbacks) and -q/-v."""

from __future__ import annotations

import click

from startrack.input_checks import Bounds, check_attitude, check_number, parse_number


class Number(click.ParamType):
    """A number option checked by startrack.input_checks: finite, of the right type, inside
    ``bounds``; an error is one line naming the option (``--sigma-px: 1e+200 is out of
    range (0, 50]``)."""

    def __init__(self, bounds: Bounds) -> None:
        self.bounds = bounds
        self.name = "integer" if bounds.integer else "float"

    def convert(self, value, param, ctx):
        where = max(param.opts, key=len) if param is not None else "value"
        return parse_number(value, where, self.bounds)

    def get_metavar(self, param, ctx=None) -> str:
        return f"{self.name.upper()} {self.bounds}"


def triple(names: str, bounds: Bounds | None = None):
    """A click callback parsing ``A,B,C`` into three finite floats (None stays None):
    an attitude RA,DEC,ROLL checked as one, else each value within ``bounds``."""
    def parse(ctx, param, value):
        if value is None:
            return None
        where = max(param.opts, key=len)
        try:
            parts = tuple(float(p) for p in value.split(","))
        except ValueError:
            parts = ()
        if len(parts) != 3:
            raise click.BadParameter(f"expected three numbers {names}, got {value!r}")
        if bounds is None:
            return check_attitude(parts, where)
        return tuple(float(check_number(p, where, bounds)) for p in parts)
    return parse


class SkyName(click.ParamType):
    """``--sky``: a sky kind, or the path of a catalog file (.csv, .fits, .parquet) that
    must exist; the file's rows are checked when it is loaded."""

    name = "KIND|FILE"

    def convert(self, value, param, ctx):
        from pathlib import Path

        from startrack.sky import SKY_KINDS, is_catalog_path

        if value in SKY_KINDS:
            return value
        if is_catalog_path(value):
            if not Path(value).is_file():
                self.fail(f"{value}: catalog file not found", param, ctx)
            return value
        self.fail(f"{value!r} is neither one of {', '.join(SKY_KINDS)} nor a catalog file "
                  "(.csv, .fits, .parquet)", param, ctx)


SKY_NAME = SkyName()
SKY_HELP = ("Catalog: a kind, or your own catalog file (.csv, .fits, .parquet; columns ra, "
            "dec, mag, optional pm_ra, pm_dec, epoch, id: docs/conventions.md).")


def _set_index_dir(ctx, param, value):
    from startrack.sky import set_index_dir

    set_index_dir(value)
    return value


def index_dir_option(command):
    """``--index-dir DIR``: where the tycho2 sky's astrometry.net index files are."""
    return click.option(
        "--index-dir", type=click.Path(file_okay=False, exists=True), expose_value=False,
        callback=_set_index_dir,
        help="Folder of astrometry.net Tycho-2 index files for --sky tycho2 (default: "
             "$STARTRACK_INDEX_DIR, else /usr/share/astrometry, /usr/local/astrometry/data)."
    )(command)
def verbosity(command):
    """``-q/--quiet`` and ``-v/--verbose``, the same on every command (docs/conventions.md):
    -q prints nothing on stderr but errors and warnings (no progress, no notes); -v adds a
    line per step or input. Results on stdout and written files are the same either way."""
    command = click.option("-v", "--verbose", is_flag=True,
                           help="A line on stderr per step or input.")(command)
    return click.option("-q", "--quiet", is_flag=True,
                        help="Nothing on stderr but errors and warnings.")(command)


def notes(quiet: bool, verbose: bool):
    """``(note, detail)``: print a note on stderr unless -q; a detail only with -v; slow
    table builds are announced unless -q."""
    from startrack.io import announce_builds  # the cache's module loads numpy: on use

    announce_builds(not quiet)

    def note(text: str) -> None:
        if not quiet:
            click.echo(text, err=True)

    def detail(text: str) -> None:
        if verbose and not quiet:
            click.echo(text, err=True)
    return note, detail

__all__ = [
    "Number", "SKY_HELP", "SKY_NAME", "SkyName", "index_dir_option", "notes", "triple",
    "verbosity",
]
