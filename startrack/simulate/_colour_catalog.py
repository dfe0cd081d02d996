"""Catalog colours for the band model: Hipparcos-2 B-V, or Gaia DR3 BP-RP as its B-V
equivalent, by catalog row (NaN where unknown)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from startrack._core.sky import parse
from startrack.io import cached_parse
from startrack.simulate._colour import bv_from_bp_rp
from startrack.sky import Catalog, catalog_file, fixed_width_column, gaia_bp_rp

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


def _lookup(keys: np.ndarray, values: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """``values`` at ``wanted`` in the ascending ``keys`` (NaN where absent)."""
    out = np.full(len(wanted), np.nan)
    if len(keys) == 0 or len(wanted) == 0:
        return out
    where = np.clip(np.searchsorted(keys, wanted), 0, len(keys) - 1)
    found = keys[where] == wanted
    out[found] = values[where[found]]
    return out


def catalog_bv(catalog: Catalog) -> np.ndarray:
    """B-V of every catalog row: the Hipparcos-2 value for a HIP star of a Hipparcos or
    Tycho-2 sky (whose ids are HIP numbers for HIP stars); for a Gaia sky, the B-V
    equivalent of the star's BP-RP (:func:`startrack.simulate._colour.bv_from_bp_rp`), or the
    Hipparcos-2 B-V of its Hipparcos entries (id -HIP); NaN otherwise."""
    sky = catalog.source.get("sky", catalog.source.get("kind"))
    kind = sky.get("kind") if isinstance(sky, dict) else sky
    ids = np.asarray(catalog.ids, dtype=np.int64)
    if kind in ("hipparcos", "tycho2"):
        return _lookup(*hipparcos_bv(), ids)
    out = np.full(len(catalog), np.nan)
    if kind == "gaia":
        gaia = ids >= 0
        out[gaia] = bv_from_bp_rp(_lookup(*gaia_bp_rp(), ids[gaia]))
        out[~gaia] = _lookup(*hipparcos_bv(), -ids[~gaia])
    return out

__all__ = ["catalog_bv", "hipparcos_bv"]
