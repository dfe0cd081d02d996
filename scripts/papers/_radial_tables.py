"""The radial-features paper's Tables 2 to 4: its own rows checked for consistency, and
the same three tables made on one of our frames (its camera, a known sky patch).

The paper's rows (scripts/data/radial_features_paper_rows.csv) are its printed numbers
(pixel x, y; "longitude, latitude" in degrees), typed from the paper, not measured here.
"""

from __future__ import annotations

from pathlib import Path

import astropy.units as u
import numpy as np
import pandas as pd
from astropy.coordinates import SkyCoord

from startrack.bench import bench_frame, label_every_star, load_bench, point_patch

#: the paper's printed rows, one a line: table, row, pixel x, y, and its "longitude,
#: latitude" (deg); Table 2 lists a star once per candidate
PAPER_ROWS_CSV = Path(__file__).resolve().parents[1] / "data" / "radial_features_paper_rows.csv"
#: the sky frames the printed "longitude, latitude" are tried in (astropy names)
FRAMES = ("icrs", "fk4", "galactic", "geocentrictrueecliptic", "supergalactic")


def paper_rows() -> pd.DataFrame:
    """The paper's Tables 2 to 4 as printed (:data:`PAPER_ROWS_CSV`), read to the last bit
    of each typed number.

    Returns
    -------
    pandas.DataFrame
        Columns table, row, x, y (px), lon, lat (deg).
    """
    return pd.read_csv(PAPER_ROWS_CSV, float_precision="round_trip")


def sky_vectors(lon_deg, lat_deg) -> np.ndarray:
    lon, lat = np.radians(lon_deg), np.radians(lat_deg)
    return np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


def similarity_fit(rows: pd.DataFrame) -> tuple[float, np.ndarray]:
    """Fit pixels to the tangent plane of the rows' sky positions by scale, rotation (or
    reflection) and shift; the fitted scale (deg per pixel) and each row's residual
    (arcsec), the better of the two handednesses."""
    v = sky_vectors(rows["lon"], rows["lat"])
    c = v.mean(axis=0) / np.linalg.norm(v.mean(axis=0))
    e1 = np.cross([0.0, 0.0, 1.0], c)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(c, e1)
    plane = np.degrees(np.column_stack([v @ e1, v @ e2]) / (v @ c)[:, None])
    best = None
    for flip in (1.0, -1.0):
        z = rows["x"].to_numpy() + 1j * flip * rows["y"].to_numpy()
        w = plane[:, 0] + 1j * plane[:, 1]
        a = np.column_stack([z, np.ones_like(z)])
        coef = np.linalg.lstsq(a, w, rcond=None)[0]
        resid = np.abs(a @ coef - w) * 3600.0
        if best is None or resid.sum() < best[1].sum():
            best = (float(abs(coef[0])), resid)
    return best


def paper_checks(catalog, f_px: float) -> pd.DataFrame:
    """The paper's rows with, per row, the residual of Table 3's similarity fit (Table 3
    only), the distance to the nearest catalog star reading the positions in each of
    :data:`FRAMES` (arcsec) and whether the same
    navigation star is another observed star's identity elsewhere in Tables 2 and 3."""
    rows = paper_rows()
    t3 = rows["table"] == 3
    scale, resid = similarity_fit(rows[t3])
    rows["fit_resid_arcsec"] = np.nan
    rows.loc[t3, "fit_resid_arcsec"] = resid
    rows["fit_scale_deg_px"] = np.where(t3, scale, np.nan)
    rows["stated_scale_deg_px"] = np.degrees(1.0 / f_px)
    for frame in FRAMES:
        icrs = SkyCoord(rows["lon"].to_numpy() * u.deg, rows["lat"].to_numpy() * u.deg,
                        frame=frame).icrs
        near = np.degrees(np.arccos(np.clip(sky_vectors(icrs.ra.deg, icrs.dec.deg)
                                            @ catalog.vectors.T, -1.0, 1.0))).min(axis=1)
        rows[f"nearest_{frame}_arcsec"] = near * 3600.0
    star = rows["lon"].round(3).astype(str) + "," + rows["lat"].round(3).astype(str)
    pixel = rows["x"].round(0).astype(str) + "," + rows["y"].round(0).astype(str)
    two = rows["table"].isin((2, 3))
    owners = pd.Series(pixel[two].values, index=star[two].values).groupby(level=0).nunique()
    rows["star_owners_t2_t3"] = star.map(owners).where(two)
    return rows


def _example_frame(spec, tries: int = 40):
    """The first frame of the 1 px, 2 false-star condition (else the last condition)
    where sss_patch misidentifies a star: the frame our Tables 2 to 4 are made on."""
    cond = next((k for k, c in enumerate(spec.conditions)
                 if c.noise_px == 1.0 and c.false_stars == 2), len(spec.conditions) - 1)
    bench = load_bench(spec)
    for frame in range(min(tries, spec.frames)):
        _, _, bf = bench_frame(spec, cond, frame)
        sss = bench.identifier("sss_patch", bf.obs.camera).matcher
        point_patch(sss, bf)
        labels = label_every_star(sss, bf.obs)
        given = labels.cat_row >= 0
        if np.any(given & (labels.cat_row != bf.truth_rows)):
            return cond, frame, bf, labels
    return cond, frame, bf, labels


def our_tables(spec) -> pd.DataFrame:
    """Tables 2 (radial_patch's shortlists of the ten brightest stars), 3 (its labels)
    and 4 (sss_patch's wrong labels) on :func:`_example_frame`'s frame."""
    cond, frame, bf, sss_labels = _example_frame(spec)
    bench = load_bench(spec)
    radial = bench.identifier("radial_patch", bf.obs.camera).matcher
    point_patch(radial, bf)
    cat = bench.identifiers["radial_patch"].catalog
    rows = []

    def add(table, k, c):
        level = spec.conditions[cond]
        rows.append({"table": table, "condition": cond, "noise_px": level.noise_px,
                     "false_stars": level.false_stars, "frame": frame, "star": k,
                     "x": bf.obs.x[k], "y": bf.obs.y[k], "ra": cat.ra_deg[c] if c >= 0
                     else np.nan, "dec": cat.dec_deg[c] if c >= 0 else np.nan,
                     "true": bool(c >= 0 and c == bf.truth_rows[k]),
                     "false_star": bool(bf.truth_rows[k] < 0)})

    for k, short in enumerate(radial.shortlists(bf.obs, min(10, len(bf.obs)))):
        for c in short:
            add(2, k, int(c))
    for k, c in enumerate(label_every_star(radial, bf.obs).cat_row):
        add(3, k, int(c))
    for k, c in enumerate(sss_labels.cat_row):
        if c >= 0 and c != bf.truth_rows[k]:
            add(4, k, int(c))
    return pd.DataFrame(rows)


def tables(spec) -> dict[str, pd.DataFrame]:
    """The two saved tables: ``paper_tables`` (the paper's rows, checked) and
    ``our_tables`` (the same tables on our frame)."""
    bench = load_bench(spec)
    some = next(iter(bench.identifiers.values()))
    return {"paper_tables": paper_checks(some.catalog, spec.camera.f_px),
            "our_tables": our_tables(spec)}
