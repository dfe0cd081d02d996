"""Option types and parsers shared by the commands (click types and callbacks)."""

from __future__ import annotations

import click

from startrack.validate import Bounds, check_attitude, check_number, parse_number


class Number(click.ParamType):
    """A number option checked by startrack.validate: finite, of the right type, inside
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
