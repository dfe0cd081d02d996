"""Scoring: one method's answer on one frame against the truth, and summaries per condition.

A solution is *correct* when its pointing (boresight) is within the threshold of the
truth AND every star it reports is identified right; a solution that is accepted but not
correct is *wrong* (the failure a star tracker must not make). Not solving is neither.

The threshold is ``threshold_arcsec`` (default 60") or, when the centroids are noisier,
``NOISE_SIGMAS`` times the stated 1-sigma centroid error, whichever is larger: a correct
identification can only be as accurate as its centroids. The boresight error is used,
not the total rotation angle, because in a narrow field the roll about the boresight is
several times less well determined than the pointing (17.5 deg, 0.5 px noise: median
roll error ~60", pointing ~9"), and would mark right identifications as wrong.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from startrack.match_records import Solution

DEFAULT_THRESHOLD_ARCSEC = 60.0
NOISE_SIGMAS = 5.0
_RAD_TO_ARCSEC = np.degrees(1.0) * 3600.0


@dataclass(frozen=True)
class FrameScore:
    """One method on one frame (a row of frames.csv after the condition columns)."""

    solved: bool
    correct: bool
    wrong: bool
    n_observed: int  # spots handed to the matcher
    n_real_observed: int  # of which real catalog stars (the ones that can be identified)
    n_true_in_view: int  # catalog stars in the image before dropout
    n_identified: int  # stars the solution reports
    n_id_correct: int
    n_id_wrong: int
    error_arcsec: float  # total attitude error (rotation angle); NaN when not solved
    boresight_error_arcsec: float
    roll_error_arcsec: float
    #: the boresight error up to which this frame's answer counts as correct
    threshold_arcsec: float
    #: why the frame is not correct, in a word: "" (correct), the unsolved frame's reason
    #: ("no_match", "too_few_stars", "timeout", ...), or for a wrong answer "wrong_star"
    #: (a reported star misidentified) or "pointing" (boresight beyond the threshold)
    reason: str
    identify_ms: float  # the identify call: matching, verification, attitude
    # The method's own time, which the summary reports: the identify call for our methods,
    # the peer's solve call alone for a peer solver (its own matching and checks).
    method_ms: float
    centroid_ms: float
    candidates: int
    pivots: int
    hypotheses: int

    def to_dict(self) -> dict:
        return asdict(self)


def attitude_errors(truth: Rotation, estimate: Rotation) -> tuple[float, float, float]:
    """(total, boresight, roll) errors in arcsec between two camera-to-ICRS attitudes.

    The relative rotation truth^-1 * estimate is expressed in the camera frame, so its
    z component is the roll about the boresight.
    """
    rel = (truth.inv() * estimate).as_rotvec()
    total = float(np.linalg.norm(rel) * _RAD_TO_ARCSEC)
    roll = float(abs(rel[2]) * _RAD_TO_ARCSEC)
    za, zb = truth.apply([0.0, 0.0, 1.0]), estimate.apply([0.0, 0.0, 1.0])
    # atan2 keeps small angles exact where arccos of a dot product loses them.
    boresight = float(np.arctan2(np.linalg.norm(np.cross(za, zb)), za @ zb) * _RAD_TO_ARCSEC)
    return total, boresight, roll


def score_frame(solution: Solution, truth_rows: np.ndarray, truth_rotation: Rotation,
                n_true_in_view: int, *, centroid_ms: float = 0.0,
                threshold_arcsec: float = DEFAULT_THRESHOLD_ARCSEC,
                sigma_arcsec: float = 0.0) -> FrameScore:
    """Score ``solution`` for a frame whose observed star k is catalog row truth_rows[k]
    (-1: a false star); ``sigma_arcsec`` is the centroids' stated 1-sigma error."""
    truth_rows = np.asarray(truth_rows, dtype=np.int64)
    diag = solution.diagnostics
    n_id_correct = n_id_wrong = 0
    error = boresight = roll = float("nan")
    correct = False
    limit = threshold_for(threshold_arcsec, sigma_arcsec)
    reason = solution.reason or "no_match"
    if solution.solved:
        obs_index = np.asarray(solution.obs_index, dtype=np.int64)
        right = truth_rows[obs_index] == np.asarray(solution.cat_index, dtype=np.int64)
        n_id_correct = int(right.sum())
        n_id_wrong = int(len(right) - n_id_correct)
        error, boresight, roll = attitude_errors(truth_rotation, solution.rotation)
        correct = boresight <= limit and n_id_wrong == 0
        reason = "" if correct else "wrong_star" if n_id_wrong else "pointing"
    return FrameScore(
        solved=bool(solution.solved),
        correct=bool(correct),
        wrong=bool(solution.solved and not correct),
        n_observed=len(truth_rows),
        n_real_observed=int(np.count_nonzero(truth_rows >= 0)),
        n_true_in_view=int(n_true_in_view),
        n_identified=len(solution.obs_index) if solution.solved else 0,
        n_id_correct=n_id_correct,
        n_id_wrong=n_id_wrong,
        error_arcsec=error,
        boresight_error_arcsec=boresight,
        roll_error_arcsec=roll,
        threshold_arcsec=float(limit),
        reason=reason,
        identify_ms=float(solution.identify_ms),
        method_ms=float(solution.identify_ms if diag.method_ms is None else diag.method_ms),
        centroid_ms=float(centroid_ms),
        candidates=int(diag.candidates),
        pivots=int(diag.pivots),
        hypotheses=int(diag.hypotheses),
    )


def threshold_for(threshold_arcsec: float, sigma_arcsec: float) -> float:
    """The boresight error up to which an answer is correct: ``threshold_arcsec``, or
    :data:`NOISE_SIGMAS` times the centroids' stated 1-sigma error when that is larger."""
    return max(float(threshold_arcsec), NOISE_SIGMAS * float(sigma_arcsec))


def _percentile(values: pd.Series, q: float) -> float:
    values = values.to_numpy(dtype=float)
    return float(np.percentile(values, q)) if len(values) else float("nan")


def _ratio(num: float, den: float) -> float:
    return float(num) / float(den) if den else float("nan")


def _median(values: pd.Series) -> float:
    values = values.to_numpy(dtype=float)
    return float(np.median(values)) if len(values) else float("nan")


def _summarise_group(g: pd.DataFrame) -> dict:
    solved = g["solved"].astype(bool)
    ok = g["correct"].astype(bool)
    ms = g["method_ms"].to_numpy(dtype=float)
    cms = g["centroid_ms"].to_numpy(dtype=float)
    return {
        "frames": len(g),
        "solved_rate": solved.mean(),
        "correct_rate": ok.mean(),
        "wrong_rate": g["wrong"].astype(bool).mean(),
        "wrong": int(g["wrong"].astype(bool).sum()),
        # Precision: reported identities that are right; recall: identifiable (real,
        # observed) stars that were identified right.
        "star_precision": _ratio(g["n_id_correct"].sum(), g["n_identified"].sum()),
        "star_recall": _ratio(g["n_id_correct"].sum(), g["n_real_observed"].sum()),
        # the correctness threshold (the same for every frame of a condition)
        "threshold_arcsec": float(g["threshold_arcsec"].max()) if "threshold_arcsec" in g
        else float("nan"),
        # total: the whole rotation's angle (roll included); boresight: the pointing, on
        # which correctness is judged; roll: about the boresight
        "error_median_arcsec": _median(g.loc[ok, "error_arcsec"]),
        "error_p95_arcsec": _percentile(g.loc[ok, "error_arcsec"], 95),
        "boresight_median_arcsec": _median(g.loc[ok, "boresight_error_arcsec"]),
        "boresight_p95_arcsec": _percentile(g.loc[ok, "boresight_error_arcsec"], 95),
        "roll_median_arcsec": _median(g.loc[ok, "roll_error_arcsec"]),
        "roll_p95_arcsec": _percentile(g.loc[ok, "roll_error_arcsec"], 95),
        "time_median_ms": float(np.median(ms)),
        "time_p95_ms": float(np.percentile(ms, 95)),
        "time_mean_ms": float(np.mean(ms)),
        "centroid_median_ms": float(np.median(cms)),
    }


def summarise(frames: pd.DataFrame, key_columns: list[str]) -> pd.DataFrame:
    """One row per (condition, method) group of ``frames`` (columns of FrameScore plus
    ``key_columns``), in the order the groups first appear. Attitude errors are taken over
    correct solutions only; times over every attempt."""
    rows = []
    for key, g in frames.groupby(key_columns, sort=False):
        rows.append({**dict(zip(key_columns, key, strict=True)), **_summarise_group(g)})
    return pd.DataFrame(rows)

__all__ = [
    "DEFAULT_THRESHOLD_ARCSEC", "FrameScore", "NOISE_SIGMAS", "attitude_errors", "score_frame",
    "summarise", "threshold_for",
]
