"""Option parsers shared by the commands (click callbacks)."""

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


class SkyName(click.ParamType):
    """``--sky``: a sky kind, or the path of a catalog file (.csv, .fits, .parquet) that
    must exist; the file's rows are checked when it is loaded."""

    name = "KIND|FILE"

    def convert(self, value, param, ctx):
        from pathlib import Path

        from startrack.sky import SKY_KINDS
        from startrack.sky.user_catalog import is_catalog_path

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
    from startrack.sky.tycho2 import set_index_dir

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
