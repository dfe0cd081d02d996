"""Solving one input with hints (:mod:`startrack.solver._hints`) through the pipeline.

A hinted input is solved by a child :class:`~startrack.solver._pipeline.Pipeline` whose options
carry the hinted field of view (a nominal FOV and tolerance covering the scale range) and
whose catalogs are cut to the hinted cone; the parent's loaded catalogs are shared. An
answer outside the hinted radius is refused. Hints taken from a FITS header alone are a
guess about a file that may have been edited: when they lead nowhere the input is solved
again as if they were absent (the user's own hints are not second-guessed).
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict

from startrack.defaults import BLIND_FOV_RANGE
from startrack.errors import InputError
from startrack.match_records import Solution
from startrack.solver._hints import (
    Hints,
    cone_radius_deg,
    fov_range_deg,
    header_hints,
    within_hint,
)
from startrack.solver._identifier import FrameResult, frame_timing
from startrack.solver._inputs import FrameInput

#: hinted child pipelines kept per parent (a batch of FITS frames has one hint each)
MAX_CHILDREN = 4


def frame_hints(pipeline, frame: FrameInput) -> Hints | None:
    """The hints for one input: the user's, and (unless ``header_hints`` is off) its FITS
    header's when the field of view is not known otherwise (options, camera, sidecar, a
    scale range): a known one is solved in milliseconds from the tables loaded once for
    the batch, which a cone per frame would rebuild for each. None: no hint."""
    opt = pipeline.options
    if opt.hints is None and (frame.path is None or not opt.header_hints):
        return None  # no hint given, no header to read (a centroid list in memory)
    user = opt.hints or Hints()
    if frame.path is None or not opt.header_hints or user.scale is not None:
        return user or None
    header = header_hints(frame.path, opt.size or frame.size)
    if header is None or pipeline.setup_for(frame)[0] is not None:
        return user or None
    return Hints(user.pointing or header.pointing, header.scale, from_header=True)


def solve_hinted(pipeline, frame: FrameInput, hints: Hints) -> FrameResult:
    """:meth:`Pipeline.identify_frame` for an input with ``hints``."""
    child = _child(pipeline, frame, hints)
    child.sigma_px = pipeline.sigma_px  # this input's, as the parent decided it
    found = child.identify_unhinted(frame)
    sol = found.solution
    if sol.solved and hints.pointing is not None and not within_hint(sol.rotation,
                                                                       hints.pointing):
        sol = Solution(False, sol.method, diagnostics=sol.diagnostics,
                       identify_ms=sol.identify_ms, reason="no_match")
        found = dataclasses.replace(found, solution=sol,
                                    timing=frame_timing(frame, sol.identify_ms))
    if sol.solved or not hints.from_header or sol.reason in ("too_few_stars", "timeout"):
        return found
    user = pipeline.options.hints
    again = (solve_hinted(pipeline, frame, user) if user else
             pipeline.identify_unhinted(frame))
    spent = sol.identify_ms + again.solution.identify_ms
    solution = dataclasses.replace(again.solution, identify_ms=spent)
    return dataclasses.replace(again, solution=solution, timing=frame_timing(frame, spent))


def _child(pipeline, frame: FrameInput, hints: Hints):
    """The pipeline (cached per hint and image size) that solves with ``hints``."""
    children = pipeline.__dict__.setdefault("_hinted", OrderedDict())
    key = (hints, frame.size)
    if key in children:
        children.move_to_end(key)
        return children[key]
    opt = dataclasses.replace(pipeline.options, hints=None, header_hints=False)
    if hints.scale is not None:
        size = opt.size or frame.size
        if size is None:
            raise InputError(f"{frame.name}: a centroid list with a scale range needs the "
                             "image size (--size WxH)")
        fov, tol = fov_range_deg(hints.scale, size[0])
        opt = dataclasses.replace(opt, camera=None, fov_deg=fov, fov_tolerance=tol)
    child = type(pipeline)(opt, catalogs=pipeline.catalogs, setup=pipeline.setup,
                           trail=pipeline.trail)
    if hints.pointing is not None:
        camera = child.setup_for(frame)[0]
        child.cone = (hints.pointing, cone_radius_deg(
            hints.pointing, camera, opt.fov_tolerance, BLIND_FOV_RANGE[1]))
    children[key] = child
    while len(children) > MAX_CHILDREN:
        children.popitem(last=False)
    return child
