"""Centroids: the observed stars of one frame, and the interfaces.md centroid CSV."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from startrack.errors import InputError

# 1-sigma centroid error assumed when none is given: rendered and real frames centroid to
# a few tenths of a pixel (scripts/bench_centroid.py); 0.5 px also leaves room for small
# lens distortion. identify, the Python API and compare --from images all assume it.
DEFAULT_SIGMA_PX = 0.5


@dataclass(frozen=True)
class Centroids:
    """Observed star positions in pixels, sorted brightest first.

    ``flux`` is linear brightness (background removed); ``saturated`` flags spots with a
    saturated pixel; ``area`` is the spot's pixel count (0 when unknown).
    """

    x: np.ndarray
    y: np.ndarray
    flux: np.ndarray
    saturated: np.ndarray = field(default=None)  # type: ignore[assignment]
    area: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        n = len(self.x)
        fields = {
            "x": np.asarray(self.x, dtype=np.float64),
            "y": np.asarray(self.y, dtype=np.float64),
            "flux": np.asarray(self.flux, dtype=np.float64),
            "saturated": np.zeros(n, bool) if self.saturated is None
            else np.asarray(self.saturated, dtype=bool),
            "area": np.zeros(n, np.int64) if self.area is None
            else np.asarray(self.area, dtype=np.int64),
        }
        order = np.argsort(-fields["flux"], kind="stable")
        for name, arr in fields.items():
            if arr.shape != (n,):
                raise ValueError(f"centroids: {name} has shape {arr.shape}, expected ({n},)")
            object.__setattr__(self, name, arr[order])

    def __len__(self) -> int:
        return len(self.x)

    def brightest(self, n: int) -> Centroids:
        return Centroids(self.x[:n], self.y[:n], self.flux[:n], self.saturated[:n],
                         self.area[:n])


def read_centroid_csv(path: str | Path) -> Centroids:
    """Read an interfaces.md centroid CSV: header, ``x``, ``y``, optional ``flux``.

    Without a flux column the rows are taken as listed brightest first.
    """
    import pandas as pd

    path = Path(path)
    try:
        table = pd.read_csv(path)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable CSV ({first})") from None
    table.columns = [str(c).strip() for c in table.columns]
    for col in ("x", "y"):
        if col not in table.columns:
            raise InputError(f"{path}: missing column '{col}' (columns: "
                             f"{', '.join(table.columns) or 'none'})")
    cols = ["x", "y"] + (["flux"] if "flux" in table.columns else [])
    values = table[cols].apply(pd.to_numeric, errors="coerce")
    bad = values.isna().any(axis=1) | ~np.isfinite(values.to_numpy(dtype=float)).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"{path}: line {row + 2}: x, y and flux must be finite numbers")
    x = values["x"].to_numpy(float)
    y = values["y"].to_numpy(float)
    flux = values["flux"].to_numpy(float) if "flux" in values else np.arange(len(x), 0, -1.0)
    return Centroids(x, y, flux)


def write_centroid_csv(path: str | Path, centroids: Centroids) -> None:
    import pandas as pd

    pd.DataFrame({"x": centroids.x, "y": centroids.y, "flux": centroids.flux}).to_csv(
        path, index=False, float_format="%.4f")
