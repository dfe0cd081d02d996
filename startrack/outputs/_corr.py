"""The correspondence table of solved frames (like astrometry.net's ``.corr``): one row per
identified star with its observed pixel and flux, its catalog entry and the residual."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from startrack.io import atomic_text
from startrack.outputs._annotate import residual_pixels
from startrack.sky import vectors_to_radec

#: Columns; units are in the names (px: pixels as in docs/conventions.md, deg, arcsec).
CORR_COLUMNS = [
    "input", "x_px", "y_px", "flux", "catalog_id", "catalog_mag", "catalog_ra_deg",
    "catalog_dec_deg", "catalog_x_px", "catalog_y_px", "observed_ra_deg",
    "observed_dec_deg", "residual_arcsec", "residual_x_px", "residual_y_px",
]


def corr_rows(frame) -> list[list]:
    """The rows of one :class:`~startrack.solver._identifier.FrameResult`; none when not solved."""
    sol = frame.solution
    if not sol.solved or sol.rotation is None or len(sol.obs_index) == 0:
        return []
    k, rows = sol.obs_index, sol.cat_index
    cat = frame.catalog
    dx, dy = residual_pixels(frame)
    ra_obs, dec_obs = vectors_to_radec(sol.rotation.apply(frame.obs.vectors[k]))
    ra_obs, dec_obs = np.atleast_1d(ra_obs), np.atleast_1d(dec_obs)
    flux = frame.centroids.flux[k] if len(frame.centroids) == len(frame.obs) else \
        np.full(len(k), math.nan)
    out = []
    for j in range(len(k)):
        out.append([
            frame.input, float(frame.obs.x[k[j]]), float(frame.obs.y[k[j]]),
            float(flux[j]), int(cat.ids[rows[j]]), float(cat.mag[rows[j]]),
            float(cat.ra_deg[rows[j]]), float(cat.dec_deg[rows[j]]),
            float(frame.obs.x[k[j]] - dx[j]), float(frame.obs.y[k[j]] - dy[j]),
            float(ra_obs[j]), float(dec_obs[j]), float(sol.residual_arcsec[j]),
            float(dx[j]), float(dy[j]),
        ])
    return out


def write_corr(path: str | Path, rows: list[list]) -> None:
    """Write correspondence ``rows`` (:func:`corr_rows`) as a CSV, atomically."""
    path = Path(path)
    with atomic_text(path) as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(CORR_COLUMNS)
        writer.writerows(rows)
