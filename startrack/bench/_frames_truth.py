"""The checks a ``compare --frames-dir`` folder's truth passes before anything is scored:
truth.csv and stars.csv are well formed and agree with each other and with the sky.

A truth that disagrees with its own star table (attitudes shifted by a row, a catalog
reordered after ``simulate``, a bad ``is_false`` cell) would score every right answer
"wrong"; it is refused with one line naming the file, the line or the frame instead.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.errors import InputError
from startrack.sky import BadId, exact_ids

#: truth and stars disagree when a frame's drawn stars lie, in the median, farther than
#: this from where its truth attitude puts them (aberration and proper motion stay far
#: below it) or farther than MAX_DRAWN_OFFSET_PX pixels, whichever is larger
MAX_DRAWN_OFFSET_ARCSEC = 120.0
MAX_DRAWN_OFFSET_PX = 5.0


def _where(path: Path, row: int) -> str:
    return f"--frames-dir: {path}: line {row + 2}"  # line 1 is the header


def _frame_numbers(path: Path, values: pd.Series) -> np.ndarray:
    """A ``frame`` column as non-negative integers (a fraction is never truncated)."""
    numbers = pd.to_numeric(values, errors="coerce").to_numpy(np.float64)
    bad = np.flatnonzero(~np.isfinite(numbers) | (numbers != np.round(numbers))
                         | (numbers < 0) | (numbers >= 2.0**53))
    if len(bad):
        cell = str(values.iloc[bad[0]])
        raise InputError(f"{_where(path, int(bad[0]))}: frame {cell!r} is not a frame number "
                         "(an integer from 0)")
    return numbers.astype(np.int64)


def check_truth(folder: Path, truth: pd.DataFrame) -> pd.DataFrame:
    """truth.csv with integer, unique frame numbers and file names and unit quaternions."""
    path = folder / "truth.csv"
    truth = truth.copy()
    truth["frame"] = _frame_numbers(path, truth["frame"])
    for column in ("frame", "file"):
        repeated = np.flatnonzero(truth[column].duplicated().to_numpy())
        if len(repeated):
            row = int(repeated[0])
            raise InputError(f"{_where(path, row)}: {column} {truth[column].iloc[row]} is "
                             "listed twice (each frame is one row)")
    q = truth[["qw", "qx", "qy", "qz"]].apply(pd.to_numeric, errors="coerce") \
        .to_numpy(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        norm = np.sqrt((q * q).sum(axis=1))
    bad = np.flatnonzero(~np.isfinite(norm) | (np.abs(norm - 1.0) > 1e-3))
    if len(bad):
        raise InputError(f"{_where(path, int(bad[0]))}: the quaternion qw,qx,qy,qz has length "
                         f"{norm[bad[0]]:.6g}, not 1 (a unit quaternion, camera to ICRS)")
    return truth


def check_stars(folder: Path, stars: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """stars.csv with integer frames of truth.csv, exact catalog ids and 0/1 is_false."""
    path = folder / "stars.csv"
    if stars.empty:
        raise InputError(f"--frames-dir: {path}: lists no star; truth.csv lists "
                         f"{len(truth)} frame(s) (stars.csv is the stars drawn in each)")
    stars = stars.copy()
    stars["frame"] = _frame_numbers(path, stars["frame"])
    unknown = np.flatnonzero(~stars["frame"].isin(truth["frame"]).to_numpy())
    if len(unknown):
        row = int(unknown[0])
        raise InputError(f"{_where(path, row)}: frame {stars['frame'].iloc[row]} is not in "
                         "truth.csv")
    flags = pd.to_numeric(stars["is_false"], errors="coerce").to_numpy(np.float64)
    bad = np.flatnonzero(~np.isin(flags, (0.0, 1.0)))
    if len(bad):
        raise InputError(f"{_where(path, int(bad[0]))}: is_false "
                         f"{stars['is_false'].iloc[bad[0]]!r} is not 0 or 1")
    try:
        ids = exact_ids(stars["catalog_id"].to_numpy())
    except BadId as exc:
        raise InputError(f"{_where(path, exc.row)}: catalog_{exc}") from None
    real = flags == 0
    bad = np.flatnonzero(real & (ids < 0))
    if len(bad):
        raise InputError(f"{_where(path, int(bad[0]))}: a real star (is_false 0) with "
                         f"catalog_id {ids[bad[0]]}")
    stars["catalog_id"], stars["is_false"] = ids, ~real
    repeated = np.flatnonzero((stars.duplicated(["frame", "catalog_id"]).to_numpy() & real)
                              | stars.duplicated(["frame", "x", "y"]).to_numpy())
    if len(repeated):
        row = int(repeated[0])
        raise InputError(f"{_where(path, row)}: repeats an earlier row of frame "
                         f"{stars['frame'].iloc[row]} (a star is drawn once)")
    return stars


def check_agreement(folder: Path, truth: pd.DataFrame, stars: pd.DataFrame, catalog,
                    camera) -> None:
    """Refuse a folder whose truth attitudes do not put the catalog stars of stars.csv
    where stars.csv draws them, or whose stars.csv names ids the sky does not hold."""
    from startrack.attitude import from_quaternion

    real = stars[~stars["is_false"]]
    rows = catalog.index_of(real["catalog_id"].to_numpy())
    missing = int(np.count_nonzero(rows < 0))
    if missing * 2 > len(rows):
        raise InputError(f"--frames-dir: {folder / 'stars.csv'}: {missing} of {len(rows)} "
                         "catalog_ids are not in the sidecars' sky; truth and sky disagree "
                         "(another catalog?), nothing scored")
    limit = max(math.radians(MAX_DRAWN_OFFSET_ARCSEC / 3600.0),
                MAX_DRAWN_OFFSET_PX / camera.f_px)
    frames = real["frame"].to_numpy()
    for row in truth.itertuples(index=False):
        mine = (frames == row.frame) & (rows >= 0)
        if not mine.any():
            continue
        rotation = from_quaternion(np.array([row.qw, row.qx, row.qy, row.qz], float))
        drawn = camera.pixel_to_vector(real["x"].to_numpy(float)[mine],
                                       real["y"].to_numpy(float)[mine])
        seen = rotation.inv().apply(catalog.vectors[rows[mine]])
        offset = float(np.median(np.arccos(np.clip((drawn * seen).sum(axis=1), -1, 1))))
        if not offset <= limit:
            raise InputError(
                f"--frames-dir: {folder}: truth.csv and stars.csv disagree: frame "
                f"{row.frame}'s attitude puts its {int(mine.sum())} catalog stars a median "
                f"{math.degrees(offset) * 3600:.0f} arcsec from where stars.csv draws them "
                "(rows shifted? another catalog?); nothing scored")

__all__ = ["check_agreement", "check_stars", "check_truth"]
