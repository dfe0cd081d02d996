"""The radial-features experiment's saved tables: per-condition counts (verified, raw,
every-star labels) and the paired tests of each claim's two methods on the same frames."""

from __future__ import annotations

import numpy as np
import pandas as pd

from startrack.bench import mcnemar_exact, summarise_raw

KEYS = ["condition", "noise_px", "false_stars", "method"]
#: (A, B): the paper's comparison lost in space and inside a known patch (against our
#: side-side-side and against its equation 5 alone), its literal method in the patch, and
#: ours against the planar triangles
PAIRS = (("radial", "sss"), ("radial_patch", "sss_patch"), ("radial_paper_patch", "sss_patch"),
         ("radial_patch", "sss_paper_patch"), ("radial_paper_patch", "sss_paper_patch"),
         ("radial", "triangle"))
#: measure name -> (table, per-frame success as a function of the table's rows): A's
#: frame is a success where B's is not (McNemar); for a count, "lower"/"higher" compares
#: the two methods' values on the frame (a sign test: A's success is A's value beating B's)
MEASURES = {
    "verified correct": ("frames", lambda t: t["correct"].astype(bool)),
    "raw first hypothesis right": ("raw", lambda t: t["first_right"].astype(bool)),
    "no misidentified star": ("labels", lambda t: t["misidentified"] == 0),
    "no star given twice": ("labels", lambda t: t["duplicates"] == 0),
    "fewer misidentified stars": ("labels", ("lower", "misidentified")),
    "more stars labelled right": ("labels", ("higher", "right")),
    "matcher faster": ("raw", ("lower", "matcher_ms")),
}


def combine(summary: pd.DataFrame, raw: pd.DataFrame, frames: pd.DataFrame) -> pd.DataFrame:
    """Verified and raw counts side by side, one row per (condition, method)."""
    verified = summary[["condition", "method", "frames", "correct_rate", "wrong",
                        "time_median_ms"]].copy()
    verified["correct"] = np.rint(verified.pop("correct_rate") * verified["frames"]).astype(int)
    ids = frames.groupby(["condition", "method"], sort=False)["n_id_wrong"].sum()
    verified = verified.merge(ids.rename("verified_wrong_ids").reset_index())
    rs = summarise_raw(raw, KEYS).rename(columns={"frames": "raw_frames"})
    rs["first_right"] = np.rint(rs["first_right_rate"] * rs["raw_frames"]).astype(int)
    rs["none"] = np.rint(rs["none_rate"] * rs["raw_frames"]).astype(int)
    rs = rs[KEYS + ["raw_frames", "first_right", "first_wrong_frames", "none", "wrong_ids",
                    "false_star_ids", "duplicates", "wrong_before_mean"]]
    g = raw.groupby(["condition", "method"], sort=False)
    extra = g.agg(seq_ms_median=("seq_ms", "median"), matcher_ms_median=("matcher_ms", "median"),
                  cand_median=("candidates", "median")).reset_index()
    extra["seq_ms_p95"] = g["seq_ms"].quantile(0.95).to_numpy()
    if "x_mean_shortlist" in raw:
        extra["shortlist_mean"] = g["x_mean_shortlist"].mean().to_numpy()
    return rs.merge(verified, on=["condition", "method"]).merge(extra,
                                                                on=["condition", "method"])


def label_summary(labels: pd.DataFrame) -> pd.DataFrame:
    """Per (condition, method): images, stars, identified, right, misidentified (sum and
    per image), images with any misidentified star, duplicates, median label time."""
    g = labels.groupby(KEYS, sort=False)
    out = g.agg(images=("frame", "size"), stars=("stars", "sum"), real=("real", "sum"),
                identified=("identified", "sum"), right=("right", "sum"),
                misidentified=("misidentified", "sum"),
                false_labelled=("false_labelled", "sum"), duplicates=("duplicates", "sum"),
                misid_per_image=("misidentified", "mean"),
                label_ms_median=("label_ms", "median")).reset_index()
    out["images_misid"] = g["misidentified"].apply(lambda s: int((s > 0).sum())).to_numpy()
    out["images_clean"] = out["images"] - out["images_misid"]
    out["misid_sd"] = g["misidentified"].std(ddof=1).fillna(0.0).to_numpy()
    return out


def _one_test(measure: str, cond, part: pd.DataFrame, success, a: str, b: str) -> dict | None:
    if isinstance(success, tuple):  # a count compared frame by frame
        sense, column = success
        wide = part.pivot_table(index=["condition", "frame"], columns="method",
                                values=column, aggfunc="first")
        if a not in wide or b not in wide:
            return None
        wide = wide[[a, b]].dropna()
        va, vb = (wide[a], wide[b]) if sense == "lower" else (wide[b], wide[a])
        t = mcnemar_exact((va < vb).to_numpy(), (vb < va).to_numpy())
        return {"measure": measure, "condition": cond, "a": a, "b": b, "frames": t.frames,
                "a_ok": t.only_a, "b_ok": t.only_b, "only_a": t.only_a,
                "only_b": t.only_b, "p": t.p}
    wide = part.assign(ok=success(part)).pivot_table(
        index=["condition", "frame"], columns="method", values="ok", aggfunc="first")
    if a not in wide or b not in wide:
        return None
    wide = wide[[a, b]].dropna().astype(bool)
    t = mcnemar_exact(wide[a].to_numpy(), wide[b].to_numpy())
    return {"measure": measure, "condition": cond, "a": a, "b": b, "frames": t.frames,
            "a_ok": t.both + t.only_a, "b_ok": t.both + t.only_b, "only_a": t.only_a,
            "only_b": t.only_b, "p": t.p}


def paired_tests(frames: pd.DataFrame, raw: pd.DataFrame, labels: pd.DataFrame) -> pd.DataFrame:
    """Exact McNemar of every claim pair on every measure, per condition and pooled over all
    conditions (condition -1); a count (time, misidentified or right stars) is a sign test
    of the two methods' values frame by frame."""
    sources = {"frames": frames, "raw": raw, "labels": labels}
    rows = []
    for measure, (source, success) in MEASURES.items():
        table = sources[source]
        groups = [(-1, table), *table.groupby("condition", sort=True)]
        for cond, part in groups:
            for a, b in PAIRS:
                row = _one_test(measure, int(cond), part, success, a, b)
                if row is not None:
                    rows.append(row)
    out = pd.DataFrame(rows)
    cond = frames.drop_duplicates("condition").set_index("condition")
    out["noise_px"] = out["condition"].map(cond["noise_px"])
    out["false_stars"] = out["condition"].map(cond["false_stars"])
    return out
