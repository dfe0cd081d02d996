"""The radial-features section's text on the paper's Tables 2 to 4: what the paper's own
rows say when checked against each other, and the same tables on one of our frames."""

from __future__ import annotations

import numpy as np
import pandas as pd


def _star(r) -> str:
    return f"({r.lon:.4f}, {r.lat:.4f})"


def _pix(r) -> str:
    return f"({r.x:.2f}, {r.y:.2f})"


def _shared(rows: pd.DataFrame) -> list[str]:
    """Table 2 stars with a single candidate that Table 3 gives to another observed star."""
    t2, t3 = rows[rows["table"] == 2], rows[rows["table"] == 3]
    out = []
    for _, g in t2.groupby("row"):
        if len(g) != 1:
            continue
        q = g.iloc[0]
        other = t3[(t3["lon"].round(3) == round(q.lon, 3)) & (t3["lat"].round(3) == round(q.lat, 3))
                   & (np.hypot(t3["x"] - q.x, t3["y"] - q.y) > 1.0)]
        for r in other.itertuples():
            gone = not (np.hypot(t3["x"] - q.x, t3["y"] - q.y) < 0.05).any()
            out.append(f"Table 2 row {int(q.row)} gives the star at {_pix(q)} px the single "
                       f"candidate {_star(q)}; Table 3 row {r.row} gives {_star(r)} to the "
                       f"star at {_pix(r)} px, "
                       f"{np.hypot(r.x - q.x, r.y - q.y):.0f} px away"
                       + (", and leaves the first star out" if gone else ""))
    return out


def _digits(rows: pd.DataFrame) -> list[str]:
    """The same observed star with different printed coordinates in Tables 2 and 3."""
    t2, t3 = rows[rows["table"] == 2], rows[rows["table"] == 3]
    out = []
    for r in t3.itertuples():
        same = t2[(np.hypot(t2["x"] - r.x, t2["y"] - r.y) < 0.05)]
        if same.empty:
            continue
        if not ((same["lon"] == r.lon) & (same["lat"] == r.lat)).any() or \
                not ((same["x"] == r.x) & (same["y"] == r.y)).any():
            out.append(f"Table 3 row {r.row} {_pix(r)} -> {_star(r)}, Table 2: "
                       + ", ".join(f"{_pix(s)} -> {_star(s)}" for s in same.itertuples()))
    return out


def _absent(rows: pd.DataFrame) -> int:
    t2, t3 = rows[rows["table"] == 2], rows[rows["table"] == 3]
    return int(sum(not (np.hypot(t3["x"] - r.x, t3["y"] - r.y) < 0.05).any()
                   for r in t2.drop_duplicates("row").itertuples()))


def paper_tables_text(rows: pd.DataFrame) -> str:
    t3 = rows[rows["table"] == 3]
    scale, stated = t3["fit_scale_deg_px"].iloc[0], rows["stated_scale_deg_px"].iloc[0]
    resid = t3["fit_resid_arcsec"]
    lines = [
        f"Tables 2 and 3 list {rows.loc[rows['table'] == 2, 'row'].nunique()} and "
        f"{len(t3)} observed stars; Table 2 gives "
        f"{int((rows[rows['table'] == 2].groupby('row').size() > 1).sum())} of them two "
        "candidates. Checked against each other (scripts/papers/_radial_tables.py):",
        "**Tables 2 and 3 contradict each other**: " + "; ".join(_shared(rows))
        + f". In all, {_absent(rows)} of Table 2's stars are absent from Table 3.",
        "the same observed star is printed with different digits: " + "; ".join(_digits(rows))
        + ".",
        f"Table 3's pixels and sky positions agree only at a scale of {scale:.3e} deg per "
        f"pixel (a similarity fit of all {len(t3)} pairs) where the stated camera gives "
        f"{stated:.3e} ({stated * 4096:.2f} deg over 4096 px against "
        f"{scale * 4096:.2f}); the fit leaves {resid.median():.0f}\" median and "
        f"{resid.max():.0f}\" largest residual (row {int(t3.loc[resid.idxmax(), 'row'])}), "
        f"{resid.median() / (scale * 3600):.0f} and {resid.max() / (scale * 3600):.0f} px, "
        "far above a centroid error.",
        "the printed positions are not those of catalog stars: read in each sky frame, "
        "the nearest catalog star (the bench's Hp <= 8 sky) is "
        + "; ".join(f"{c[8:-7]} {rows[c].min():.0f}\" to {rows[c].max():.0f}\""
                    for c in rows.columns if c.startswith("nearest_"))
        + " away. The paper does not say which frame its \"longitude, latitude\" are "
        "in, so its images cannot be re-identified; its tables are compared in kind only.",
    ]
    return ("### The paper's Tables 2 to 4\n\n" + lines[0] + "\n\n"
            + "".join(f"* {x}\n" for x in lines[1:]) + "\n")


def our_tables_text(ours: pd.DataFrame) -> str:
    if ours.empty:
        return ""
    r0 = ours.iloc[0]
    level = (f"noise {r0.noise_px:g} px, {int(r0.false_stars)} false stars"
             if "noise_px" in ours else f"condition {int(r0.condition)}")
    head = (f"### The same tables on our frame {int(r0.frame)} ({level}, known patch)\n\n"
            "The first frame of that condition where the plain triangle method "
            "misidentifies a star; `true`: the label is the star's catalog star.\n\n")
    parts = []
    for table, what in ((2, "initial identification: `radial_patch`'s shortlists of the "
                            "ten brightest stars"),
                        (3, "identification: `radial_patch`, every star labelled"),
                        (4, "misidentified stars of the plain triangle method "
                            "(`sss_patch`, every star labelled)")):
        part = ours[ours["table"] == table]
        shown = part[["star", "x", "y", "ra", "dec", "true", "false_star"]].to_string(
            index=False, float_format=lambda v: f"{v:.2f}") if len(part) else "(none)"
        per = part.groupby("star").size() if len(part) else pd.Series(dtype=int)
        summary = (f" {int((per > 1).sum())} of {len(per)} stars have several candidates,"
                   f" {int(part.groupby('star')['true'].any().sum())} hold the true one."
                   if table == 2 and len(part) else "")
        parts.append(f"Table {table} ({what}).{summary}\n\n```\n{shown}\n```\n")
    return head + "\n".join(parts) + "\n"
