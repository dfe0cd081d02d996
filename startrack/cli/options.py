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


def finite(ctx, param, value):
    """A click callback refusing NaN and infinity (None stays None)."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"must be a finite number, got {value}")
    return value
