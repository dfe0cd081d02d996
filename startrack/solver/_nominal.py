"""A nominal field of view (``--fov`` within ``--fov-tolerance``): the quad search within
the tolerance, then the configured method's first look and its FOV refit, then the
search on a deeper sky and the whole configured method; and the frame with too few stars
for any of it, answered before a sky is loaded. Functions of a
:class:`~startrack.solver._pipeline.Pipeline`, as :mod:`startrack.solver._solve_with_hints`'s
are."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from startrack.camera import Camera
from startrack.defaults import BLIND_FOV_RANGE
from startrack.errors import InputError
from startrack.match_records import Observation, Solution
from startrack.matchers import get_matcher
from startrack.sky import Catalog, SkySpec, check_pair_budget, search_sky_kind
from startrack.solver._deadline import Deadline
from startrack.solver._fov_refit import refit_fov
from startrack.solver._fov_search import solve_approximate
from startrack.solver._identifier import FrameResult, Identifier, frame_timing
from startrack.solver._inputs import FrameInput
from startrack.verify import VerifyConfig

#: a tolerance wider than this is a range (``--scale-low/--scale-high``, say), not a
#: nominal FOV and its error: the range's centre is no better a guess than its ends, and
#: the configured method's first look there, which matches only within a few tenths of a
#: percent of the true FOV, is not tried (the configured method, all its stars, still
#: follows where nothing else answered)
FIRST_LOOK_MAX_TOLERANCE = 0.2


def too_few_stars(pipeline, frame: FrameInput, camera: Camera | None,
                   sky: SkySpec) -> FrameResult:
    """Not solved, "too_few_stars", with no sky loaded and no table built: fewer stars
    than any pattern holds identify nothing, and a deep sky's first use for a new
    camera costs minutes and GBs (a blank frame at a narrow FOV)."""
    if camera is None:
        camera = Camera.from_fov(*pipeline._blind_size(frame),
                                 math.sqrt(BLIND_FOV_RANGE[0] * BLIND_FOV_RANGE[1]))
    obs = Observation.from_pixels(frame.centroids.x, frame.centroids.y, camera,
                                  pipeline.sigma_px)
    sol = Solution(False, pipeline.options.method, reason="too_few_stars")
    pipeline.trail.add("method", pipeline.options.method, sky, camera.fov_deg, sol)
    empty = Catalog(ids=np.zeros(0, np.int64), ra_deg=np.zeros(0), dec_deg=np.zeros(0),
                    mag=np.zeros(0), source=sky.to_dict())
    return FrameResult(frame.name, sol, obs, frame.centroids, frame_timing(frame, 0.0),
                       camera, empty, pipeline.sigma_px, VerifyConfig().radius_px(obs),
                       frame.image)

def approximate(pipeline, frame: FrameInput, camera: Camera, sky: SkySpec):
    """A nominal FOV, each stage where the ones before it found nothing: the quad search
    within the tolerance on the chosen sky (scale-free: the nominal FOV's error costs it
    nothing, and it answers through the nominal camera where that fits); the configured
    method's first look (its brightest stars,
    :attr:`~startrack.solver._identifier.Identifier.first_look`) at the nominal FOV, its
    FOV refitted; the search on the deeper default sky; the configured method with all
    its stars. A :class:`FrameResult` when the configured method's answer stands (too few
    stars, a timeout), else the search's ``FovResult``; its time counts every stage's."""
    stars = (frame.centroids.x, frame.centroids.y, frame.centroids.measured_flux())
    nominal = _nominal_identifier(pipeline, camera, sky)
    deadline = Deadline.after_ms(pipeline.options.timeout_ms)  # with every table loaded
    found = _search(pipeline, stars, camera, sky, deadline, deeper=False)
    if _answered(found):
        return found
    # the time of the stages that gave no answer, which the answer's time includes
    spent = 0.0 if found is None else found.solution.identify_ms
    if nominal is not None and pipeline.options.fov_tolerance <= FIRST_LOOK_MAX_TOLERANCE:
        first, ms = _first_look(pipeline, frame, nominal, camera, sky, deadline)
        if isinstance(first, FrameResult):
            return _plus_ms(first, frame, spent)
        if first is not None:
            return first.plus_ms(spent)
        spent += ms
    deeper = _search(pipeline, stars, camera, sky, deadline, deeper=True)
    if deeper is not None:
        found = deeper
        if _answered(found):
            return found.plus_ms(spent)
        spent += found.solution.identify_ms
    # ``found`` is the last search's (its own time is in ``spent`` already)
    found = found.plus_ms(spent - found.solution.identify_ms)
    return found if nominal is None else _whole_method(frame, nominal, deadline, found)

def _answered(found) -> bool:
    return found is not None and (found.solution.solved or found.solution.reason == "timeout")

def _plus_ms(result: FrameResult, frame: FrameInput, ms: float) -> FrameResult:
    """``result`` with ``ms`` more spent on it (stages before it that gave no answer)."""
    sol = dataclasses.replace(result.solution, identify_ms=result.solution.identify_ms + ms)
    return dataclasses.replace(result, solution=sol,
                               timing=frame_timing(frame, sol.identify_ms))

def _nominal_identifier(pipeline, camera: Camera, sky: SkySpec) -> Identifier | None:
    """The configured method's identifier at the nominal FOV, loaded (its refit warmed)
    before the input's time limit starts; None for a scale-free method (the search is
    its own) or where its tables do not fit (a deep narrow-field sky)."""
    method = pipeline.options.method
    if get_matcher(method).scale_free or not _tables_fit(pipeline, camera, sky):
        return None
    fresh = (camera, sky, method) not in pipeline._identifiers
    nominal = pipeline.identifier(camera, sky)
    if fresh:  # the refit's first use too
        with pipeline.setup.counting():
            nominal.warm_refit(refit_fov)
    return nominal

def _first_look(pipeline, frame: FrameInput, nominal: Identifier, camera: Camera,
                sky: SkySpec, deadline: Deadline):
    """(the first look's answer, the ms it spent): a ``FrameResult`` where it stands (too
    few stars, a timeout), its refitted ``FovResult`` where it solved (that time
    counted in it), else None."""
    first = nominal.solve(frame, identify=lambda obs: nominal.identify(
        obs, deadline, first_look=True))
    pipeline.trail.add("first look (brightest stars)", pipeline.options.method, sky,
                       camera.fov_deg, first.solution)
    ms = first.solution.identify_ms
    if first.solution.reason in ("too_few_stars", "timeout"):
        return first, ms
    found = (refit_fov(first, nominal.database, nominal.verify_config, deadline)
             if first.solution.solved else None)
    if first.solution.solved and found is None:
        pipeline.trail.add("FOV refit", pipeline.options.method, sky, camera.fov_deg,
                           result="rejected")
    return (None if found is None else found.plus_ms(ms)), ms

def _whole_method(frame: FrameInput, nominal: Identifier, deadline: Deadline, failed):
    """The configured method with all its stars at the nominal FOV, its FOV refitted:
    the last try where the first look (its brightest stars alone: a false star or a
    missing one among them matches nothing) and the search both failed; else
    ``failed``, the search's answer."""
    whole = nominal.solve(frame, identify=lambda obs: nominal.identify(obs, deadline))
    found = refit_fov(whole, nominal.database, nominal.verify_config, deadline) \
        if whole.solution.solved else None  # its time counts the whole method's
    if found is None:
        return failed.plus_ms(whole.solution.identify_ms)
    return found.plus_ms(failed.solution.identify_ms)

def _search(pipeline, stars, camera: Camera, sky: SkySpec, deadline: Deadline,
            deeper: bool):
    """The quad search within the tolerance for ``stars`` (x, y, measured flux or
    None): on the chosen sky (``deeper`` False); with
    the default sky, also (``deeper``) over the whole of the search sky
    (:func:`startrack.sky._default.search_sky_kind`: Tycho-2 where the field needs it,
    else Gaia) cut per window, its brightest stars ordered by its own magnitudes. None
    where that search is not made (the chosen sky is the search sky, or not the
    default)."""
    tol, opt = pipeline.options.fov_tolerance, pipeline.options
    x, y, flux = stars
    default = opt.sky is None and opt.mag_limit is None
    deep = search_sky_kind(camera)
    window = (camera.fov_deg * (1 - tol), camera.fov_deg * (1 + tol))
    if not deeper:
        if default and sky.kind == deep:
            return None
        found = solve_approximate(pipeline.identifier(camera, sky, "quad"), x, y, tol, deadline,
                                  flux)
        pipeline.trail.add("FOV search", "quad", sky, window, found.solution)
        return found
    if not default:
        return None
    deep_sky = SkySpec(kind=deep, epoch=opt.epoch)
    found = pipeline.blind_solver(deep_sky).solve(x, y, (camera.width, camera.height),
                                              deadline, camera, tol, flux=flux)
    pipeline.trail.add("FOV search, deeper sky", "quad", deep_sky, window, found.solution)
    return found

def _tables_fit(pipeline, camera: Camera, sky: SkySpec) -> bool:
    """Whether the configured method's pair table for ``camera`` fits the pair budget
    (:func:`startrack.sky.check_pair_budget`); a Gaia sky for a 1.5 to 4 deg field
    does not, and the quad search, which tables no pairs, then answers alone."""
    if not get_matcher(pipeline.options.method).tables or (
            camera, sky, pipeline.options.method) in pipeline._identifiers:
        return True
    try:
        check_pair_budget(pipeline.catalog(sky, camera), camera)
    except InputError:
        return False
    return True
