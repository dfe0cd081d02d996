"""The parts of report.md that make it stand alone: what the run was (camera, sky, frames,
star budget, threshold, warm-up, machine and its load), how to read the table, and a
check of the first timed frame of every method against the rest."""

from __future__ import annotations

import os

import pandas as pd

from startrack.bench._metrics import NOISE_SIGMAS
from startrack.solver import sky_text

#: a method's first timed frame slower than this many times its median is reported
FIRST_FRAME_RATIO = 5.0

HOW_TO_READ = (
    "Each row is one method on one condition (the simulated errors in its first columns) "
    "over the same frames. *solved*: the method gave an answer that passed verification; "
    "*correct*: every star it reported is the right catalog star and its boresight "
    "(where it points) is within the row's *threshold*; *wrong*: an answer given but not "
    "correct, the failure a star tracker must not make; solved = correct + wrong. "
    "Brackets are 95% Wilson intervals over the frames. The errors are over correct "
    "answers, median / 95th percentile, in arcsec: *boresight* is the pointing error "
    "(correctness is judged on it), *roll* the rotation about the boresight (a narrow "
    "field fixes it several times less well than the pointing) and *total* the whole "
    "rotation's angle, roll included. *Precision*: reported identities that are right; "
    "*recall*: identifiable stars (real stars in the frame) that were identified right. "
    "Times are each method's own time per frame, warm (see *warm-up* below), median and "
    "95th percentile over every frame, solved or not.")


def camera_text(camera) -> str:
    text = (f"{camera.width} x {camera.height} px, horizontal FOV {camera.fov_deg:.3f} deg, "
            f"focal length {camera.f_px:.1f} px")
    if getattr(camera, "distortion", None) is not None:
        text += f", lens distortion {camera.distortion}"
    return text


def load_text(load: tuple[float, float, float] | None) -> str:
    return "-" if load is None else "{:.2f} / {:.2f} / {:.2f}".format(*load)


def machine_load() -> tuple[float, float, float] | None:
    """The load average over 1, 5 and 15 minutes (None where the system has none)."""
    try:
        return os.getloadavg()
    except (OSError, AttributeError):
        return None


def star_budget_text(max_stars: int, extra_stars: int | None) -> str:
    extra = ("the matchers' default (MatcherConfig.extra_stars, 4)" if extra_stars is None
             else str(extra_stars))
    return (f"patterns from the {max_stars} brightest stars (--max-stars); when those all "
            f"fail, methods that can add fainter ones add up to {extra}")


def threshold_text(threshold_arcsec: float) -> str:
    return (f"a boresight error up to max({threshold_arcsec:g} arcsec, {NOISE_SIGMAS:g} x "
            "the centroids' stated 1-sigma error) counts as correct; each condition's "
            "value is the table's *threshold* column")


def description_rows(description: dict, load_start, load_end) -> list[str]:
    """The "Run" table of report.md: ``description``'s rows, then the machine."""
    rows = list(description.items())
    rows.append(("machine", f"{os.cpu_count()} CPU core(s) (the model: Provenance, below)"))
    rows.append(("load average (1 / 5 / 15 min)",
                 f"{load_text(load_start)} at the start, {load_text(load_end)} at the end "
                 "(times on a loaded machine are slower and vary more)"))
    lines = ["| | |", "|---|---|"]
    lines += [f"| {k} | {str(v).replace('|', '/')} |" for k, v in rows]
    return lines


def first_frame_lines(frames: pd.DataFrame) -> list[str]:
    """Whether each method's first timed frame was as fast as the rest of its condition.
    frames.csv's first row (condition 0, frame 0) is the first frame a process timed: a
    --frames-dir run goes in order, and a generated run hands its units out in order, so
    the first goes to a fresh worker (a resumed run's first may not). It is flagged when
    slower than both the condition's 95th percentile and FIRST_FRAME_RATIO x its median
    (one frame alone also varies with the machine's load)."""
    lines = []
    for method, rows in frames.groupby("method", sort=False):
        first = rows.iloc[0]
        ms = rows.loc[rows["condition"] == first["condition"], "method_ms"].astype(float)
        median, p95, probe = float(ms.median()), float(ms.quantile(0.95)), float(
            first["method_ms"])
        slow = median > 0 and probe > max(p95, FIRST_FRAME_RATIO * median)
        verdict = (f"NOT WARM? {probe / median:.0f} x the median: a one-time cost, or the "
                   "machine's load" if slow else "as warm as the rest")
        lines.append(f"- {method}: first timed frame {probe:.2f} ms; its condition's median "
                     f"{median:.2f} ms, p95 {p95:.2f} ms: {verdict}")
    return lines


def lost_in_space_description(spec, workers: str) -> dict:
    """The "Run" rows of a generated comparison (a :class:`~startrack.bench._runner.RunSpec`)."""
    warm = ("in every worker process each method first solves a throwaway frame (its "
            "kernels compiled, its lazy tables filled)"
            + (", and one frame is rendered and extracted" if spec.source == "images"
               else "") + ", before its first timed frame; the bench refuses to time a "
            "method that was not warmed")
    return {
        "methods": ", ".join(spec.methods),
        "camera": camera_text(spec.camera),
        "sky": sky_text(spec.sky),
        "frames": f"{spec.frames} per condition x {len(spec.conditions)} condition(s) "
                  f"({spec.grid} grid), seed {spec.seed}, from {spec.source}",
        "star budget": star_budget_text(spec.max_stars, spec.extra_stars),
        "threshold": threshold_text(spec.threshold_arcsec),
        "warm-up": warm,
        "workers": workers,
    }


def frames_dir_description(data, methods, max_stars: int, threshold_arcsec: float) -> dict:
    """The "Run" rows of a ``--frames-dir`` comparison (a
    :class:`~startrack.bench._frames_dir.FramesFolder`)."""
    return {
        "methods": ", ".join(methods),
        "frames": f"{len(data.truth)} frame(s) of {data.folder} (one condition)",
        "camera": camera_text(data.camera) + " (the sidecars')",
        "sky": sky_text(data.sky) + " (the sidecars')",
        "star budget": star_budget_text(max_stars, None),
        "threshold": threshold_text(threshold_arcsec),
        "warm-up": "each method first solves a throwaway frame, then the folder's first "
                   "frame once untimed (read, centroids found, solved), before its first "
                   "timed frame; frames run in order in one process",
        "workers": "1 process, in order",
    }


__all__ = [
    "FIRST_FRAME_RATIO", "HOW_TO_READ", "camera_text", "description_rows",
    "first_frame_lines", "frames_dir_description", "load_text", "lost_in_space_description",
    "machine_load",
]
