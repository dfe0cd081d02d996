"""Input to solution: each input read once, its camera and sky decided, its stars identified.

:func:`read_input` (:mod:`startrack.solver._inputs`) turns a path (image or centroid CSV)
into a :class:`FrameInput`; an ``Identifier`` (:mod:`startrack.solver._identifier`) holds
one loaded catalog, database and matcher and turns centroids into a ``FrameResult``, the
one complete record of an input. :class:`Pipeline` decides each input's camera and sky
(options, else the JSON sidecar beside the input, else defaults) and keeps one
``Identifier`` per (camera, sky), so a batch from one camera loads everything once.
``Options.timeout_ms`` is one ``Deadline`` per input, shared by every stage of its
identification (the configured method, the FOV refit, the FOV search).
"""

from __future__ import annotations

import dataclasses
import gc
import sys
from pathlib import Path

from startrack.camera import Camera
from startrack.centroids import DEFAULT_SIGMA_PX, Centroids, frame_sigma_px
from startrack.database import StarDatabase
from startrack.defaults import BLIND_FOV_RANGE
from startrack.errors import InputError
from startrack.io import find_sidecar, read_sidecar, resident_bytes
from startrack.match_records import Timing
from startrack.matchers import get_matcher
from startrack.sky import Catalog, SkySpec, gaia_min_fov, load_sky
from startrack.solver._aberration import correct_result
from startrack.solver._deadline import Deadline, clock
from startrack.solver._deeper import (
    remaining_ms,
    renumbered,
    reordered,
    second_look_order,
    tables_to_release,
    wants_second_look,
)
from startrack.solver._fov_search import BlindSolver
from startrack.solver._hints import cut_to_cone, header_time
from startrack.solver._identifier import FrameResult, Identifier, SetupClock, frame_timing
from startrack.solver._inputs import FrameInput, read_input
from startrack.solver._nominal import approximate, too_few_stars
from startrack.solver._options import Options
from startrack.solver._setup import decide_setup
from startrack.solver._solve_with_hints import frame_hints, solve_hinted
from startrack.solver._trail import Trail, request_record
from startrack.verify import require_evidence

#: fewer stars than this make no pattern of any matcher: not solved, with nothing loaded
MIN_STARS = 3


class Pipeline:
    """Solve many inputs, each with its own camera and sky, sharing loaded databases."""

    def __init__(self, options: Options, catalogs: dict | None = None,
                 setup: SetupClock | None = None, trail: Trail | None = None) -> None:
        if options.camera is not None and options.fov_deg is not None:
            raise InputError("give a camera or a field of view, not both (the camera sets "
                             "the field of view)")
        if options.timeout_ms is not None and not options.timeout_ms >= 0:
            raise InputError(f"timeout_ms must be a number >= 0, got {options.timeout_ms}")
        self.options = options
        get_matcher(options.method)  # an unknown method fails before any work
        #: the 1-sigma centroid error of the input being solved (:meth:`solve` sets it)
        self.sigma_px = DEFAULT_SIGMA_PX if options.sigma_px is None else options.sigma_px
        self._identifiers: dict[tuple[Camera, SkySpec, str], Identifier] = {}
        self.catalogs: dict[SkySpec, Catalog] = {} if catalogs is None else catalogs
        #: (Pointing, radius_deg): the catalogs' cut (startrack.solver._solve_with_hints)
        self.cone = None
        self._cut: dict[SkySpec, Catalog] = {}
        self._blind: dict[tuple[SkySpec, tuple[float, float]], BlindSolver] = {}
        self._notes: set[str] = set()
        #: :meth:`setup_for`'s decisions by image size for inputs without a sidecar, made
        #: under the options ``_setups_for`` (the bench sets new options on a pipeline)
        self._setups: dict[tuple[int, int] | None, tuple[Camera | None, SkySpec]] = {}
        self._setups_for: Options | None = None
        self._held: dict[str, tuple[Camera, SkySpec, Identifier]] = {}
        #: one-time loads not yet reported (shared with the hinted child pipelines)
        self.setup = setup or SetupClock()
        self.trail = trail or Trail()  # the current input's stages (shared with children)
        self._hints_used = None

    def setup_for(self, frame: FrameInput) -> tuple[Camera | None, SkySpec]:
        """The camera and sky for one input: options, else sidecar, else defaults. No
        camera at all (None) means an unknown field of view: a blind search."""
        sidecar = find_sidecar(frame.path) if frame.path is not None else None
        if sidecar is not None:
            return decide_setup(self.options, frame, *read_sidecar(sidecar)[:2],
                                self._note_once)
        # without a sidecar the options and the image size decide it: once per size
        if self._setups_for is not self.options:
            self._setups_for, self._setups = self.options, {}
        if frame.size not in self._setups:
            self._setups[frame.size] = decide_setup(self.options, frame, None, None,
                                                   self._note_once)
        return self._setups[frame.size]

    def identifier(self, camera: Camera, sky: SkySpec, method: str | None = None) -> Identifier:
        """The identifier of (camera, sky, method), loaded once, the input's centroid error
        set on it: an image's is continuous, and one per value reloaded every table."""
        method = method or self.options.method
        held = self._held.get(method)  # the one asked for last: a batch asks again and again
        if held is None or held[0] is not camera or held[1] is not sky:
            if (camera, sky, method) not in self._identifiers:
                with self.setup.counting():
                    self._identifiers[camera, sky, method] = Identifier(
                        camera, self.catalog(sky, camera), method,
                        max_stars=self.options.max_stars, sigma_px=self.sigma_px,
                        timeout_ms=self.options.timeout_ms)
            held = self._held[method] = (camera, sky, self._identifiers[camera, sky, method])
        held[2].sigma_px = float(self.sigma_px)
        return held[2]

    def solve(self, frame: FrameInput) -> FrameResult:
        """Identify one input that is already read (startrack.solver._fov_search: a nominal
        or unknown field of view), its attitude corrected for aberration when the time is
        known; its centroid error the option's, else what its star images allow; its
        record says what was asked and every stage tried (``request``, ``steps``:
        startrack.solver._trail)."""
        self.sigma_px = self.frame_sigma(frame)
        return self.correct_aberration(frame, self.identify_frame(frame))

    def frame_sigma(self, frame: FrameInput) -> float:
        """The 1-sigma centroid error (px) that ``frame`` is matched with: the option's,
        else :func:`startrack.centroids.frame_sigma_px` of its stars."""
        if self.options.sigma_px is not None:
            return float(self.options.sigma_px)
        return frame_sigma_px(frame.centroids)

    def identify_frame(self, frame: FrameInput) -> FrameResult:
        """:meth:`solve` without the aberration correction: the attitude in the catalog's
        frame (what a tracker predicts from), through the fitted camera when the field
        of view was nominal or unknown; with hints, through
        :mod:`startrack.solver._solve_with_hints`."""
        self.trail.take()  # an input that failed midway leaves no stage to the next one
        hints = self._hints_used = frame_hints(self, frame)
        return (self.identify_unhinted(frame) if hints is None
                else solve_hinted(self, frame, hints))

    def identify_unhinted(self, frame: FrameInput) -> FrameResult:
        """:meth:`identify_frame` with no hint (a hinted child pipeline's own solve)."""
        camera, sky = self.setup_for(frame)
        if len(frame.centroids) < MIN_STARS:
            return too_few_stars(self, frame, camera, sky)
        # One deadline for every stage below; it starts with the configured stage loaded
        # (tables loaded later, for the FOV search, count against it).
        if camera is None or self.options.fov_tolerance > 0:
            found = self._search(frame, camera, sky)
            if isinstance(found, FrameResult):
                return found
        else:
            exact = self.identifier(camera, sky).solve(frame)
            self.trail.add("method", self.options.method, sky, camera.fov_deg, exact.solution)
            return exact
        sol = found.solution
        return FrameResult(frame.name, sol, found.obs, frame.centroids,
                           frame_timing(frame, sol.identify_ms), found.camera,
                           found.catalog, self.sigma_px, found.match_radius_px,
                           frame.image)

    def _search(self, frame: FrameInput, camera: Camera | None, sky: SkySpec):
        """The search for a nominal FOV (``camera``) or none: its ``FovResult`` (or the
        configured method's ``FrameResult`` where that stands); where it matched nothing,
        a second look past the brightest spots (:mod:`startrack.solver._deeper`), within
        the input's time limit."""
        t0, deadline = clock(), Deadline.after_ms(self.options.timeout_ms)
        held = resident_bytes()

        def search(look: FrameInput):
            if camera is None:
                return self._blind_search(look.centroids, self._blind_size(frame), sky,
                                          deadline)
            return approximate(self, look, camera, sky)

        found = search(frame)
        if isinstance(found, FrameResult) or not wants_second_look(found, len(frame.centroids)):
            return found
        options, left = self.options, remaining_ms(self.options.timeout_ms, t0)
        if left is not None and left <= 0:
            return found
        order, stage = second_look_order(frame.centroids)
        look = dataclasses.replace(frame, centroids=reordered(frame.centroids, order))
        # where the first look grew the process much (a narrow field's deep tables), its
        # searches let go, so that the second look's pages come in their place, not on top
        # (startrack.solver._deeper.RELEASE_GROWTH_BYTES)
        if tables_to_release(held):
            self._blind.clear()
            gc.collect()
        # the rest of the time limit; the centroid error of the spots it looks at (the
        # left-out ones, nebula knots or blooming, widened it)
        self.options = dataclasses.replace(options, timeout_ms=left)
        sigma, self.sigma_px = self.sigma_px, self.frame_sigma(look)
        try:
            again = search(look)
        finally:
            self.options = options
        self.trail.add(stage, "quad", sky,
                       None if camera is None else camera.fov_deg,
                       None if isinstance(again, FrameResult) else again.solution)
        if isinstance(again, FrameResult) or not again.solution.solved:
            self.sigma_px = sigma
            return found if isinstance(again, FrameResult) else found.plus_ms(
                again.solution.identify_ms)
        return renumbered(found, again, frame.centroids, order, self.sigma_px)

    def database_of(self, catalog: Catalog) -> StarDatabase | None:
        """The database an identifier already holds for ``catalog``, if any."""
        for ident in self._identifiers.values():
            if ident.catalog is catalog:
                return ident.database
        return None

    def catalog(self, sky: SkySpec, camera: Camera | None) -> Catalog:
        """The catalog of ``sky`` (for ``camera``: its close stars merged), loaded once;
        cut to :attr:`cone` when there is one."""
        if sky not in self.catalogs:
            with self.setup.counting():
                self.catalogs[sky] = load_sky(sky, camera)
        if self.cone is None:
            return self.catalogs[sky]
        if sky not in self._cut:
            self._cut[sky] = cut_to_cone(self.catalogs[sky], *self.cone)
        return self._cut[sky]

    def correct_aberration(self, frame: FrameInput, result: FrameResult,
                           camera_checked: bool = False) -> FrameResult:
        """``result`` corrected for annual aberration when the time of observation is known
        (``Options.time``, else a FITS input's DATE-OBS): startrack.solver._aberration. Every
        answer passes here: an answer without its evidence is refused (startrack.verify.
        _evidence), and each is given its setup time, request and stages tried."""
        result = require_evidence(result, camera_checked)
        when = self.options.time
        if when is None and frame.path is not None and self.options.header_hints:
            when = header_time(frame.path)
        if when is not None:
            result = correct_result(result, when)
        t = result.timing  # given what it waited for
        hints, self._hints_used = self._hints_used, None
        return result.with_record(
            Timing(t.centroid, t.identify, t.total, self.setup.take() + frame.setup_ms),
            request_record(self.options, self.setup_for, frame, hints), self.trail.take())

    def _blind_size(self, frame: FrameInput) -> tuple[int, int]:
        size = self.options.size or frame.size
        if size is None:
            raise InputError(f"{frame.name}: a centroid list with no camera needs the image "
                             "size (--size WxH), or give --camera FILE or --fov DEG")
        return size

    def _note_once(self, note: str | None) -> None:
        """Print ``note`` on stderr the first time this pipeline meets it."""
        if note and note not in self._notes:
            self._notes.add(note)
            print(note, file=sys.stderr)

    def blind_solver(self, sky: SkySpec,
                     fov_range: tuple[float, float] = BLIND_FOV_RANGE) -> BlindSolver:
        """One per (sky, range), the input's centroid error set on it: that error is
        continuous, and a solver per value (each with its cuts) grew a batch unbounded."""
        key = (sky, fov_range)
        if key not in self._blind:
            with self.setup.counting():
                self._blind[key] = BlindSolver(self.catalog(sky, None), sky, self.sigma_px,
                                               fov_range=fov_range)
        self._blind[key].sigma_px = float(self.sigma_px)
        return self._blind[key]

    def _blind_search(self, c: Centroids, size: tuple[int, int], sky: SkySpec, deadline: Deadline):
        """No FOV: the blind search of ``c`` on ``sky``; on the default Tycho-2 sky, Gaia's
        for the fields it fills (:func:`startrack.sky._default.gaia_min_fov` and wider: its
        G band orders stars as a camera does) and then Tycho-2's for the narrower ones."""
        x, y, lo, hi, split = c.x, c.y, *BLIND_FOV_RANGE, gaia_min_fov(size)
        # one memory baseline for both skies' searches; fluxes where they were measured
        seen = {"held_bytes": resident_bytes(), "flux": c.measured_flux()}
        if self.options.sky is not None or self.options.mag_limit is not None \
                or sky.kind != "tycho2" or not lo < split < hi:
            found = self.blind_solver(sky).solve(x, y, size, deadline, **seen)
            self.trail.add("blind search", "quad", sky, (lo, hi), found.solution)
            return found
        gaia = dataclasses.replace(sky, kind="gaia")
        wide = self.blind_solver(gaia, (split, hi)).solve(x, y, size, deadline, **seen)
        self.trail.add("blind search", "quad", gaia, (split, hi), wide.solution)
        if wide.solution.solved or wide.solution.reason != "no_match":
            return wide
        narrow = self.blind_solver(sky, (lo, split)).solve(x, y, size, deadline, **seen)
        self.trail.add("blind search", "quad", sky, (lo, split), narrow.solution)
        return narrow.plus_ms(wide.solution.identify_ms)

    def skip(self) -> None:
        """Nothing carries from one frame to the next (:class:`FrameSolver`)."""

    reset = skip

    def run(self, path: str | Path) -> FrameResult:
        """Read ``path`` (image or centroid CSV) once and identify its stars."""
        return self.solve(read_input(path, downsample=self.options.downsample))
