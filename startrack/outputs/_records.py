"""A solved (or unsolved) frame as output: the docs/conventions.md solution JSON, a table, CSV rows.

Everything is rendered from the JSON record (:func:`solution_record`), so the three
formats can never disagree.
"""

from __future__ import annotations

import math

import numpy as np

from startrack.attitude import to_quaternion, to_radec_roll
from startrack.match_records import Observation, Solution, Timing
from startrack.sky import Catalog
from startrack.solver import sky_record, sky_text, step_text

#: exit code of each record status (docs/conventions.md): a batch exits with the worst
EXIT_CODES = {"solved": 0, "not_solved": 1, "error": 2}

CSV_HEADER = ["input", "x", "y", "catalog_id", "ra_deg", "dec_deg", "residual_arcsec"]


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def solution_record(solution: Solution, obs: Observation, catalog: Catalog, timing: Timing,
                    input_name: str | None = None, extra: dict | None = None,
                    fov_deg: float | None = None) -> dict:
    """The docs/conventions.md solution dict; ``input`` and ``extra`` add fields, never rename.
    ``fov_deg``: the (fitted) horizontal FOV, written for a solved frame."""
    record: dict = {}
    if input_name is not None:
        record["input"] = input_name
    record["status"] = "solved" if solution.solved else "not_solved"
    if not solution.solved:
        record["reason"] = solution.reason or "no_match"
    record["method"] = solution.method
    if solution.solved:
        record["mode"] = solution.mode
    if solution.lock is not None:
        record["lock"] = solution.lock
    if solution.fallback is not None:
        record["fallback"] = solution.fallback
    record["attitude"] = None
    record["stars"] = []
    if solution.solved and solution.rotation is not None:
        q = to_quaternion(solution.rotation)
        ra, dec, roll = to_radec_roll(solution.rotation)
        record["attitude"] = {"quaternion": [float(c) for c in q], "ra_deg": ra,
                              "dec_deg": dec, "roll_deg": roll}
        if fov_deg is not None:
            record["fov_deg"] = float(fov_deg)
        rows = solution.cat_index
        record["stars"] = [
            {"x": float(obs.x[k]), "y": float(obs.y[k]), "catalog_id": int(cid),
             "ra_deg": float(ra_s), "dec_deg": float(dec_s), "residual_arcsec": float(res)}
            for k, cid, ra_s, dec_s, res in zip(
                solution.obs_index, catalog.ids[rows], catalog.ra_deg[rows],
                catalog.dec_deg[rows], solution.residual_arcsec, strict=True)
        ]
    record["timing_ms"] = timing.to_dict()
    record["false_probability"] = _finite_or_none(solution.false_probability)
    diag = solution.diagnostics
    record["diagnostics"] = {"centroids": len(obs), "hypotheses": diag.hypotheses,
                             "candidates": diag.candidates, "pivots": diag.pivots,
                             **({"refused": diag.extra["refused"]} if "refused" in diag.extra
                                else {}),
                             **(extra or {})}
    return record


def frame_record(frame, with_input: bool = True) -> dict:
    """The docs/conventions.md solution record of one input's
    :class:`~startrack.solver.FrameResult` (``input`` left out when not ``with_input``)."""
    extra = {"sigma_px": frame.sigma_px, "match_radius_px": frame.match_radius_px,
             "sky": sky_record(frame.catalog.source), "camera": frame.camera.to_dict()}
    if frame.time_utc is not None:
        extra["time_utc"] = frame.time_utc
    record = solution_record(frame.solution, frame.obs, frame.catalog, frame.timing,
                             input_name=frame.input if with_input else None, extra=extra,
                             fov_deg=frame.camera.fov_deg)
    quality = frame.quality
    if quality is not None:
        record["quality"] = quality.to_dict()
    return with_request(record, frame.request, frame.steps)


def with_request(record: dict, request: dict | None, steps: tuple) -> dict:
    """``record`` telling what was asked (``requested``: method, sky, field of view,
    hints) and every stage tried (``steps``, in order). An unsolved record's ``method`` is
    the one asked for, whatever stage gave up last."""
    if request is None:
        return record
    if record["status"] != "solved":
        record["method"] = request["method"]
    out: dict = {}
    for key, value in record.items():
        out[key] = value
        if key == "method":
            out["requested"] = request
            out["steps"] = list(steps)
    return out


def _sigma_line(quality: dict | None) -> list[str]:
    """The attitude's 1-sigma line of a table, when the record has a quality."""
    if not quality or quality.get("sigma_boresight_arcsec") is None:
        return []
    return [f"1-sigma: boresight {quality['sigma_boresight_arcsec']:.2f} arcsec, roll "
            f"{quality['sigma_roll_arcsec']:.1f} arcsec (from the fit)"]


def _request_lines(record: dict) -> list[str]:
    """The table's lines on the request and the stages tried (when there was more than
    the one asked for, or it failed)."""
    request = record.get("requested")
    if request is None:
        return []
    fov = request.get("fov_deg")
    fov_text = ("FOV unknown (blind search)" if fov is None else
                f"FOV {fov:g} deg +-{request.get('fov_tolerance', 0):.0%}")
    line = (f"requested: method {request['method']}, sky {sky_text(request['sky'])}, "
            f"{fov_text}")
    if request.get("hints"):
        line += ", hints " + ", ".join(f"{k} {v}" for k, v in request["hints"].items())
    steps = record.get("steps") or []
    if len(steps) <= 1 and record["status"] == "solved":
        return [line]
    return [line, *(f"  {k}. {step_text(step)}" for k, step in enumerate(steps, 1))]


def error_record(input_name: str, message: str) -> dict:
    """The record of an input that could not be read: ``error`` holds the stderr line."""
    return {"input": input_name, "status": "error", "error": message, "attitude": None,
            "stars": []}


def csv_rows(record: dict) -> list[list]:
    """One CSV row (:data:`CSV_HEADER`) per identified star; none when not solved."""
    name = record.get("input", "")
    return [[name, s["x"], s["y"], s["catalog_id"], s["ra_deg"], s["dec_deg"],
             s["residual_arcsec"]] for s in record["stars"]]


def format_table(record: dict) -> str:
    """A human-readable block for one input: attitude, then each identified star."""
    lines = []
    if "input" in record:
        lines.append(f"input: {record['input']}")
    if record["status"] == "error":
        return "\n".join([*lines, f"status: error: {record['error']}"]) + "\n"
    t = record["timing_ms"]
    timing = (f"timing: centroid {t['centroid']:.1f} ms, identify {t['identify']:.1f} ms, "
              f"total {t['total']:.1f} ms")
    if t.get("setup"):  # a one-time cost: its own line, outside total
        timing += f"\nsetup: {t['setup']:.1f} ms once (catalog, database and matcher loaded)"
    n_cent = record.get("diagnostics", {}).get("centroids", "?")
    if record["status"] != "solved":
        lock = f", lock {record['lock']}" if "lock" in record else ""
        lines += [f"status: not solved: {record.get('reason', 'no_match')} (method "
                  f"{record['method']}, {n_cent} centroids{lock})", *_request_lines(record),
                  timing]
        return "\n".join(lines) + "\n"
    att = record["attitude"]
    res = np.array([s["residual_arcsec"] for s in record["stars"]])
    lines += [
        f"status: solved (method {record['method']}, {record.get('mode', 'lost_in_space')}"
        + (f", lock {record['lock']}" if "lock" in record else "")
        + f", {len(res)} of {n_cent} centroids "
        f"identified, rms residual {math.sqrt(float(np.mean(res**2))):.2f} arcsec)",
        "quaternion [w, x, y, z]: [" + ", ".join(f"{c:+.9f}" for c in att["quaternion"]) + "]",
        f"boresight: RA {att['ra_deg']:.5f} deg, Dec {att['dec_deg']:+.5f} deg, "
        f"roll {att['roll_deg']:.4f} deg",
        *_sigma_line(record.get("quality")),
        *([f"field of view: {record['fov_deg']:.4f} deg (horizontal, as solved)"]
          if "fov_deg" in record else []),
        *_request_lines(record),
        timing,
        f"{'x':>9} {'y':>9} {'catalog_id':>10} {'ra_deg':>10} {'dec_deg':>10} "
        f"{'resid_as':>8}",
    ]
    lines += [f"{s['x']:9.2f} {s['y']:9.2f} {s['catalog_id']:10d} {s['ra_deg']:10.5f} "
              f"{s['dec_deg']:+10.5f} {s['residual_arcsec']:8.2f}" for s in record["stars"]]
    return "\n".join(lines) + "\n"
