"""Catalog colours for the band model: Hipparcos-2 B-V by catalog row (NaN where unknown)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from startrack._core.sky import parse
from startrack.io import cached_parse
from startrack.sky import Catalog, catalog_file, fixed_width_column

_BV_COLUMNS = {"hip": (1, 6), "bv": (153, 158)}  # I/311 ReadMe: B-V, bytes 153-158 (F6.3)
FORMAT_VERSION = 1


def _parse_bv(path: Path) -> dict[str, np.ndarray]:
    width = _BV_COLUMNS["bv"][1]
    raw = parse.records(Path(path).read_bytes(), width)
    raw = np.ascontiguousarray(raw[~parse.blank_rows(raw), :width])
    cols = {name: fixed_width_column(raw, *span) for name, span in _BV_COLUMNS.items()}
    good = np.isfinite(cols["hip"])
    return {"hip": cols["hip"][good].astype(np.int64), "bv": cols["bv"][good]}


def hipparcos_bv() -> tuple[np.ndarray, np.ndarray]:
    """(HIP numbers ascending, their B-V) from the Hipparcos-2 catalog, cached."""
    arrays = cached_parse("hipparcos_bv", catalog_file(), FORMAT_VERSION, _parse_bv)
    order = np.argsort(arrays["hip"], kind="stable")
    return arrays["hip"][order], arrays["bv"][order]


def catalog_bv(catalog: Catalog) -> np.ndarray:
    """B-V of every catalog row: the Hipparcos-2 value for a HIP star of a Hipparcos or
    Tycho-2 sky (whose ids are HIP numbers for HIP stars), NaN otherwise."""
    out = np.full(len(catalog), np.nan)
    sky = catalog.source.get("sky", catalog.source.get("kind"))
    kind = sky.get("kind") if isinstance(sky, dict) else sky
    if kind not in ("hipparcos", "tycho2"):
        return out
    hip, bv = hipparcos_bv()
    where = np.clip(np.searchsorted(hip, catalog.ids), 0, len(hip) - 1)
    found = hip[where] == catalog.ids
    out[found] = bv[where[found]]
    return out

__all__ = ["catalog_bv", "hipparcos_bv"]
