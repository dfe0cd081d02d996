"""One camera and sky loaded for identification, and the complete answer for an input.

:class:`Identifier` holds a catalog, its database and a matcher for one camera and turns
an input's centroids into a :class:`FrameResult`; :class:`startrack.solver._pipeline.Pipeline`
keeps one per (camera, sky, method).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from startrack.attitude import from_radec_roll
from startrack.camera import Camera, stars_in_view
from startrack.centroids import DEFAULT_SIGMA_PX, Centroids
from startrack.database import StarDatabase
from startrack.defaults import DEFAULT_TIMEOUT_MS
from startrack.errors import InputError
from startrack.match_records import Observation, Solution, Timing
from startrack.matchers import Matcher, MatcherConfig, get_matcher
from startrack.sky import Catalog, check_pair_budget
from startrack.solver._deadline import Deadline
from startrack.solver._inputs import FrameInput
from startrack.solver._lost_in_space import identify
from startrack.verify import Quality, VerifyConfig, refuse_without_evidence, solution_quality

#: the brightest stars a nominal field of view's first look searches
#: (:attr:`Identifier.first_look`): enough for its patterns when the FOV is right (20
#: triples of 6 stars), few enough that a FOV that is off costs a fraction of a millisecond
FIRST_LOOK_STARS = 6


@dataclass(frozen=True)
class FrameResult:
    """One input's answer with everything that produced it (its JSON record:
    :func:`startrack.outputs.frame_record`)."""

    input: str
    solution: Solution
    obs: Observation
    centroids: Centroids
    timing: Timing
    camera: Camera
    catalog: Catalog
    sigma_px: float
    match_radius_px: float
    image: np.ndarray | None = None
    time_utc: str | None = None  # observation time the attitude is corrected for (ISO)
    #: what was asked for this input (startrack.solver._trail.request_record); None: not known
    request: dict | None = None
    #: every stage tried for it, in order (startrack.solver._trail.Trail)
    steps: tuple = ()

    @property
    def quality(self) -> Quality | None:
        """Residuals, the attitude's 1-sigma and the catalog used (None: not solved)."""
        return solution_quality(self.solution, self.obs, self.catalog)

    def with_timing(self, timing: Timing) -> FrameResult:
        """This result with ``timing``: what ``dataclasses.replace`` makes, built directly
        (every answer passes here, :meth:`~startrack.solver._pipeline.Pipeline.solve`)."""
        return FrameResult(self.input, self.solution, self.obs, self.centroids, timing,
                           self.camera, self.catalog, self.sigma_px, self.match_radius_px,
                           self.image, self.time_utc, self.request, self.steps)

    def with_record(self, timing: Timing, request: dict | None, steps: tuple) -> FrameResult:
        """This result with its ``timing``, ``request`` and ``steps``, as
        :meth:`with_timing` makes it (every answer passes here last)."""
        return FrameResult(self.input, self.solution, self.obs, self.centroids, timing,
                           self.camera, self.catalog, self.sigma_px, self.match_radius_px,
                           self.image, self.time_utc, request, steps)


def frame_timing(frame: FrameInput, identify_ms: float) -> Timing:
    """An input's stage times: its centroiding, ``identify_ms``, and the total with its
    reading."""
    return Timing(frame.centroid_ms, identify_ms,
                  frame.read_ms + frame.centroid_ms + identify_ms)


def observation(centroids: Centroids, camera: Camera, sigma_px: float) -> Observation:
    """The centroids seen through ``camera`` (their flux with them when it is measured)."""
    return Observation.from_pixels(centroids.x, centroids.y, camera, sigma_px,
                                   flux=centroids.measured_flux())


class SetupClock:
    """The one-time costs paid so far (a catalog, database or warmed matcher loaded) and
    not yet reported: the next answer's ``timing_ms.setup``."""

    def __init__(self) -> None:
        self.pending_ms = 0.0
        self._running = False

    @contextlib.contextmanager
    def counting(self) -> Iterator[None]:
        """Add the block's time to :attr:`pending_ms` (once when such blocks nest)."""
        if self._running:
            yield
            return
        self._running, t0 = True, time.perf_counter()
        try:
            yield
        finally:
            self._running = False
            self.pending_ms += (time.perf_counter() - t0) * 1000.0

    def take(self) -> float:
        """The pending milliseconds, now reported (the clock starts again at zero)."""
        ms, self.pending_ms = self.pending_ms, 0.0
        return ms


class Identifier:
    """A loaded catalog, database and matcher for one camera and sky."""

    def __init__(self, camera: Camera, catalog: Catalog, method: str, *,
                 max_stars: int | None = None, extra_stars: int | None = None,
                 sigma_px: float = DEFAULT_SIGMA_PX,
                 verify_config: VerifyConfig | None = None,
                 timeout_ms: float | None = DEFAULT_TIMEOUT_MS) -> None:
        if not (sigma_px > 0 and math.isfinite(sigma_px)):
            raise InputError(f"--sigma-px must be a positive number, got {sigma_px}")
        self.camera = camera
        self.catalog = catalog
        self.sigma_px = float(sigma_px)
        self.timeout_ms = timeout_ms
        self.verify_config = verify_config or VerifyConfig()
        config = MatcherConfig()
        if max_stars is not None:
            config = dataclasses.replace(config, max_stars=int(max_stars))
        if extra_stars is not None:
            config = dataclasses.replace(config, extra_stars=int(extra_stars))
        if get_matcher(method).tables:  # the quad matcher and the peers build no pairs
            check_pair_budget(catalog, camera)  # before a database that would not fit memory
        self.database = StarDatabase(catalog, camera)
        self.matcher = get_matcher(method)(self.database, config)
        #: True once :meth:`warm_up` has solved its throwaway frame (the bench checks it)
        self.warmed_up = False
        self._warm_centroids: Centroids | None = None
        self._first_look: Matcher | None = None
        t0 = time.perf_counter()
        self.matcher.prepare()
        self.warm_up()
        self.load_seconds = time.perf_counter() - t0

    def warm_up(self) -> None:
        """Solve one throwaway frame, the stars around the catalog's brightest one, so the
        first real frame pays no one-time cost (lazy tables filled, the database's first
        lookups): that cost lands in :attr:`load_seconds`, which
        ``timing_ms.setup`` reports, and never in an input's identify time."""
        if len(self.catalog):
            pointing = from_radec_roll(float(self.catalog.ra_deg[0]),
                                       float(self.catalog.dec_deg[0]), 0.0)
            _, x, y = stars_in_view(self.catalog, self.camera, pointing)
            self._warm_centroids = Centroids(x, y, np.ones(len(x)), photometric=False)
            # A matcher searching a known sky patch is told this frame's, then given back
            # the caller's (startrack.bench._runner.point_patch sets it per frame).
            patch = getattr(self.matcher, "patch_center", None)
            if getattr(self.matcher, "patch_rad", None) is not None:
                self.matcher.patch_center = pointing.apply([0.0, 0.0, 1.0])
            try:
                identify(self.observation(self._warm_centroids), self.matcher,
                         self.verify_config)
            finally:
                if hasattr(self.matcher, "patch_center"):
                    self.matcher.patch_center = patch
        self.warmed_up = True

    def warm_refit(self, refit: Callable) -> None:
        """The first use of ``refit`` (:func:`startrack.solver._fov_refit.refit_fov`, a nominal
        FOV's refit: its kernels) and of :attr:`first_look` on the throwaway frame of
        :meth:`warm_up`."""
        if self._warm_centroids is not None:
            obs = self.observation(self._warm_centroids)
            identify(obs, self.first_look, self.verify_config)
            first = self.solve(FrameInput("warm-up", self._warm_centroids))
            if first.solution.solved:
                refit(first, self.database, self.verify_config)

    @property
    def first_look(self) -> Matcher:
        """This identifier's method on its :data:`FIRST_LOOK_STARS` brightest stars alone,
        no fainter ones added: a nominal field of view's first try
        (:mod:`startrack.solver._pipeline`). Where the nominal FOV is right it solves as
        the full method does; where it is off, no pattern matches, and the full method
        would try every pattern of up to ``max_stars + extra_stars`` stars (milliseconds)
        before the focal-length search, which solves such a frame, could start."""
        if self._first_look is None:  # made once (no cached_property lock per frame)
            matcher = self.matcher
            if matcher.brightest_first:
                config = dataclasses.replace(
                    matcher.config, extra_stars=0,
                    max_stars=min(FIRST_LOOK_STARS, matcher.config.max_stars))
                matcher = type(self.matcher)(self.database, config)
                matcher.prepare()
            self._first_look = matcher
        return self._first_look

    def observation(self, centroids: Centroids) -> Observation:
        return observation(centroids, self.camera, self.sigma_px)

    def identify(self, obs: Observation, deadline: Deadline | None = None,
                 first_look: bool = False) -> Solution:
        """Identify the stars of an observation made elsewhere (the bench's frames), by
        ``deadline`` (the input's, shared with other stages) if given, else within this
        identifier's ``timeout_ms``; with ``first_look``, by :attr:`first_look`."""
        matcher = self.first_look if first_look else self.matcher
        if deadline is not None:
            sol = identify(obs, matcher, self.verify_config, deadline=deadline)
        else:
            sol = identify(obs, matcher, self.verify_config, timeout_ms=self.timeout_ms)
        # the bench and the command line count "solved" alike (startrack.verify._evidence)
        return refuse_without_evidence(sol, self.camera.f_px, self.verify_config.radius_px(obs))

    def solve(self, frame: FrameInput,
              identify: Callable[[Observation], Solution] | None = None) -> FrameResult:
        """Identify the stars of one input read by :func:`read_input` (by ``identify``
        when given: a tracking step of :mod:`startrack.tracking._sequence`)."""
        if frame.size is not None and frame.size != (self.camera.width, self.camera.height):
            raise InputError(f"{frame.name}: image is {frame.size[0]} x {frame.size[1]} px "
                             f"but the camera is {self.camera.width} x {self.camera.height}")
        obs = self.observation(frame.centroids)
        solution = (identify or self.identify)(obs)
        timing = frame_timing(frame, solution.identify_ms)
        return FrameResult(frame.name, solution, obs, frame.centroids, timing, self.camera,
                           self.catalog, self.sigma_px, self.verify_config.radius_px(obs),
                           frame.image)
