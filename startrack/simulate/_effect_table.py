"""One reader for the effect tables of a simulation config ([optics], [detector], [environment]).

Each table is a frozen dataclass whose fields carry their documented range in their metadata
(``bounds``); a table from a file is checked key by key, every error one line naming the file,
the table and the key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import field
from typing import Any, TypeVar

from startrack.errors import InputError
from startrack.input_checks import Bounds, check_number, check_table

T = TypeVar("T")


def number(default: float, bounds: Bounds, doc: str) -> Any:
    """A dataclass field holding a number inside ``bounds`` (checked when read from a table)."""
    return field(default=default, metadata={"bounds": bounds, "doc": doc})


def choice(default: str, choices: tuple[str, ...], doc: str) -> Any:
    """A dataclass field holding one of ``choices``."""
    return field(default=default, metadata={"choices": choices, "doc": doc})


def curve(doc: str) -> Any:
    """A dataclass field holding a curve: a tuple of numbers (empty: not given)."""
    return field(default=(), metadata={"curve": True, "doc": doc})


def _value(f: dataclasses.Field, value, where: str):
    meta = f.metadata
    if "choices" in meta:
        if value not in meta["choices"]:
            raise InputError(f"{where}: must be one of {', '.join(meta['choices'])}, "
                             f"got {value!r}")
        return value
    if "curve" in meta:
        if not isinstance(value, list | tuple) or not value:
            raise InputError(f"{where}: expected a list of numbers")
        return tuple(float(check_number(v, where)) for v in value)
    if isinstance(f.default, bool):
        if not isinstance(value, bool):
            raise InputError(f"{where}: expected true or false, got {value!r}")
        return value
    return float(check_number(value, where, meta["bounds"]))


def table_from_dict(cls: type[T], data, where: str) -> T:
    """An instance of the effect table ``cls`` from ``data``; unknown keys and values out
    of range are errors naming ``where`` and the key."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    check_table(data, fields, where, cls.__name__.lower())
    values = {k: _value(fields[k], v, f"{where}: {k}") for k, v in data.items()}
    try:
        return cls(**values)
    except (InputError, ValueError) as exc:
        raise InputError(f"{where}: {exc}") from None


def changed(table) -> dict:
    """The fields of ``table`` that differ from their defaults (what a sidecar records)."""
    return {f.name: getattr(table, f.name) for f in dataclasses.fields(table)
            if getattr(table, f.name) != f.default}


def documented(cls) -> list[tuple[str, str, str]]:
    """(key, default, meaning) of every field of ``cls``, for the docs."""
    rows = []
    for f in dataclasses.fields(cls):
        meta = f.metadata
        kind = (str(meta["bounds"]) if "bounds" in meta else
                " | ".join(meta["choices"]) if "choices" in meta else
                "list" if "curve" in meta else "bool")
        rows.append((f.name, f"{f.default!r} {kind}", meta.get("doc", "")))
    return rows

__all__ = ["changed", "choice", "curve", "documented", "number", "table_from_dict"]
