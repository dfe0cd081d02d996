"""Centroids: the observed stars of one frame, and the docs/conventions.md centroid CSV."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from startrack.errors import InputError, InputFileNotFoundError, StartrackWarning

# 1-sigma centroid error assumed when none is given: rendered and real frames centroid to
# a few tenths of a pixel (scripts/bench/bench_centroid.py); 0.5 px also leaves room for small
# lens distortion. identify, the Python API and compare --from images all assume it.
DEFAULT_SIGMA_PX = 0.5
# A wide star image (defocus, bloom, seeing in a long exposure, a lens's coma) is
# centroided no better than about a tenth of its radius on real frames: blended wings,
# asymmetric aberrations and saturated cores move the centre (the wide real frames'
# stars land 1 to 5 px from their catalog places at radii of 7 to 10 px). The radius is
# that of the median detected area of the brightest stars; a compact image (a radius up
# to ~4 px: every simulated frame) keeps DEFAULT_SIGMA_PX.
SIGMA_PER_RADIUS = 0.12
MAX_FRAME_SIGMA_PX = 3.0
SIGMA_FROM_STARS = 20  # the brightest stars whose areas give the radius
# A centroid CSV keeps its brightest MAX_CENTROIDS rows (a star tracker's frame holds tens
# to hundreds of stars; more only costs memory and time); it is read CSV_CHUNK_ROWS at once.
MAX_CENTROIDS = 1000
CSV_CHUNK_ROWS = 50_000
# No centroid lies this far (px) from any image (IMAGE_SIDE_PX is at most 1e5 px); past it
# a coordinate is junk, and squaring it overflows the projection (1e300: raw warnings).
MAX_CENTROID_COORD_PX = 1e7


def bad_centroid_row(values: np.ndarray) -> int | None:
    """Index of the first row of ``values`` (x, y[, flux] columns) that is not finite or
    whose x or y lies past :data:`MAX_CENTROID_COORD_PX`; None when every row is good."""
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values).all(axis=1) | (
            np.abs(values[:, :2]) > MAX_CENTROID_COORD_PX).any(axis=1)
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


@dataclass(frozen=True)
class Centroids:
    """Observed star positions in pixels, sorted brightest first.

    ``flux`` is linear brightness (background removed); ``saturated`` flags spots with a
    saturated pixel; ``area`` is the spot's pixel count (0 when unknown); ``elongation``
    the ratio of its image's principal axes (1 for a round spot; NaN when unknown).
    ``photometric`` is False when ``flux`` only ranks the stars (a centroid list without
    a flux column): the order is then right but brightness cannot be compared with the
    catalog's magnitudes.
    """

    x: np.ndarray
    y: np.ndarray
    flux: np.ndarray
    saturated: np.ndarray = field(default=None)  # type: ignore[assignment]
    area: np.ndarray = field(default=None)  # type: ignore[assignment]
    photometric: bool = True
    elongation: np.ndarray = field(default=None)  # type: ignore[assignment]

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
            "elongation": np.full(n, np.nan) if self.elongation is None
            else np.asarray(self.elongation, dtype=np.float64),
        }
        order = np.argsort(-fields["flux"], kind="stable")
        for name, arr in fields.items():
            if arr.shape != (n,):
                raise ValueError(f"centroids: {name} has shape {arr.shape}, expected ({n},)")
            object.__setattr__(self, name, arr[order])

    def __len__(self) -> int:
        return len(self.x)

    def measured_flux(self) -> np.ndarray | None:
        """The fluxes where they were measured; None where they only rank the stars
        (``photometric`` False): the final labelling then weighs no brightness."""
        return self.flux if self.photometric else None

    def brightest(self, n: int) -> Centroids:
        return Centroids(self.x[:n], self.y[:n], self.flux[:n], self.saturated[:n],
                         self.area[:n], self.photometric, self.elongation[:n])


def frame_sigma_px(centroids: Centroids) -> float:
    """The 1-sigma centroid error the frame's star images allow (pixels): the default
    for compact images, else :data:`SIGMA_PER_RADIUS` of their radius (the median area
    of the :data:`SIGMA_FROM_STARS` brightest, as a disk), at most
    :data:`MAX_FRAME_SIGMA_PX`. A centroid list without areas gets the default."""
    area = centroids.area[:SIGMA_FROM_STARS]
    area = area[area > 0]
    if len(area) == 0:
        return DEFAULT_SIGMA_PX
    radius = float(np.sqrt(np.median(area) / np.pi))
    return float(min(MAX_FRAME_SIGMA_PX, max(DEFAULT_SIGMA_PX, SIGMA_PER_RADIUS * radius)))


def _csv_columns(path: Path) -> dict[str, str]:
    """{wanted name: the header's own spelling} for x, y and flux; errors name the file."""
    import pandas as pd  # pandas: --help loads this module, and pandas takes 0.3 s

    try:
        header = pd.read_csv(path, nrows=0)
    except FileNotFoundError:
        raise InputFileNotFoundError(f"{path}: no such file") from None
    except (OSError, ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable CSV ({first})") from None
    names = {str(c).strip(): c for c in header.columns}
    for col in ("x", "y"):
        if col not in names:
            raise InputError(f"{path}: missing column '{col}' (columns: "
                             f"{', '.join(names) or 'none'})")
    return {k: names[k] for k in ("x", "y", "flux") if k in names}


def _csv_chunks(path: Path, columns: dict[str, str]):
    """(first line number, x, y, flux or None) per chunk of rows, each checked finite."""
    import pandas as pd  # pandas: --help loads this module, and pandas takes 0.3 s

    line = 2
    try:
        reader = pd.read_csv(path, usecols=list(columns.values()), chunksize=CSV_CHUNK_ROWS)
        for chunk in reader:
            arr = np.column_stack([
                pd.to_numeric(chunk[c], errors="coerce").to_numpy(dtype=float)
                for c in columns.values()]) if len(chunk) else np.zeros((0, len(columns)))
            bad = bad_centroid_row(arr)
            if bad is not None:
                raise InputError(f"{path}: line {line + bad}: x, y and flux must be finite "
                                 f"numbers, x and y within {MAX_CENTROID_COORD_PX:g} px")
            yield line, arr[:, 0], arr[:, 1], (arr[:, 2] if arr.shape[1] > 2 else None)
            line += len(arr)
    # OverflowError: a 400-digit integer, which pandas cannot coerce to a float
    except (OSError, ValueError, OverflowError, pd.errors.ParserError,
            UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable CSV ({first})") from None


def read_centroid_csv(path: str | Path, max_rows: int | None = None) -> Centroids:
    """Read an docs/conventions.md centroid CSV: header, ``x``, ``y``, optional ``flux``.

    Without a flux column the rows are taken as listed brightest first. The file is read
    in chunks and only the brightest ``max_rows`` (default :data:`MAX_CENTROIDS`) are
    kept, with a warning saying how many were dropped: memory stays bounded whatever the
    file's length. Rows past the bound are still checked.
    """
    path = Path(path)
    limit = MAX_CENTROIDS if max_rows is None else max_rows
    columns = _csv_columns(path)
    xs, ys, fs = np.zeros(0), np.zeros(0), np.zeros(0)
    total = 0
    for first_line, x, y, flux in _csv_chunks(path, columns):
        if flux is None:  # listed brightest first: rank by position in the file
            flux = -np.arange(first_line, first_line + len(x), dtype=float)
        xs, ys, fs = np.concatenate([xs, x]), np.concatenate([ys, y]), np.concatenate([fs, flux])
        total += len(x)
        if len(fs) > limit:
            keep = np.sort(np.argsort(-fs, kind="stable")[:limit])
            xs, ys, fs = xs[keep], ys[keep], fs[keep]
    if total > limit:
        warnings.warn(f"{path}: kept the brightest {limit} of {total} centroids "
                      "(the documented bound, MAX_CENTROIDS)", StartrackWarning, stacklevel=2)
    if "flux" not in columns:
        return Centroids(xs, ys, np.arange(len(xs), 0, -1.0), photometric=False)
    return Centroids(xs, ys, fs)


def write_centroid_csv(path: str | Path, centroids: Centroids) -> None:
    import pandas as pd  # pandas: --help loads this module, and pandas takes 0.3 s

    pd.DataFrame({"x": centroids.x, "y": centroids.y, "flux": centroids.flux}).to_csv(
        path, index=False, float_format="%.4f")
