"""An approximate or unknown field of view: search the focal length, fit it, verify again.

``--fov`` (or a camera file) is a nominal value: :func:`solve_approximate` searches the
focal lengths within ``--fov-tolerance`` of it with the scale-free ``quad`` matcher (the
configured ``--method`` runs as before with ``--fov-tolerance 0``, an exact FOV). With
no field of view at all, :class:`BlindSolver` sweeps the quad matcher over
:data:`BLIND_FOV_RANGE`. Both take the windows in the order of :func:`passes`: each
window's first strongly confirmed candidate, then every candidate ranked, in windows a
factor :data:`WINDOW_STEP` wide, each verified against the catalog cut for that field (the
magnitude rule of :func:`startrack.sky.resolve_sky`). A solution is kept only if the
camera fitted to its matched stars (least squares on the focal length with the attitude)
passes the same verification (:func:`startrack.verify._verification.verify`, its binomial
bound) again; the record reports that camera's ``fov_deg``, or the given camera's when
the data do not reject it (:func:`startrack.solver._fov_given.keep_given`). Every search
takes the input's one :class:`~startrack.solver._deadline.Deadline` (``--timeout-ms``),
checked before each window and each verification: past it the input is not solved, with
reason ``"timeout"``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from startrack.camera import Camera
from startrack.database import CutCones, StarDatabase, cone_index_of
from startrack.defaults import BLIND_FOV_RANGE, DEFAULT_FOV_TOLERANCE
from startrack.io import resident_bytes, shed_memory
from startrack.match_records import MatchDiagnostics, Observation, Solution
from startrack.matchers import QuadMatcher, ScaledHypothesis
from startrack.sky import Catalog, resolve_sky
from startrack.solver._deadline import NO_DEADLINE, Deadline
from startrack.solver._fov_fit import rounds_for, verify_fitted, weighed_first
from startrack.solver._fov_given import keep_given, through_given
from startrack.solver._fov_windows import MARGIN, Pass, f_of_fov, focal_range, passes
from startrack.solver._lost_in_space import residuals_arcsec
from startrack.verify import Verification, VerifyConfig

#: a blind search keeps the databases of this many magnitude cuts in memory
KEEP_DATABASES = 2
#: ... and its cuts' cone indexes up to this many bytes (Gaia's all; Tycho-2's narrowest recut)
KEEP_CONE_BYTES = 64 << 20
#: a candidate is verified only when this many other bright stars already fall near
#: catalog stars at its attitude (verification needs two, at a tighter radius)
MIN_CONFIRMED = 2
MAX_VERIFY = 25  # hypotheses verified per window: bounded work on a junk frame
#: a candidate whose own four stars put the focal length this close to the nominal one is
#: verified through the nominal camera first (four stars fix it to about 0.1%)
GIVEN_FIRST_WITHIN = 0.003


class SearchTimeout(Exception):
    """The input's deadline passed before a search was complete."""


def _check(deadline: Deadline) -> None:
    if deadline.passed():
        raise SearchTimeout


def _solution(check: Verification, obs: Observation, database: StarDatabase, method: str,
              diag: MatchDiagnostics, t0: float) -> Solution:
    """The Solution of an accepted verification of ``obs``: its pairs and residuals as it
    measured them when it checked ``obs`` itself (pairs ascending), as an exact FOV's
    answer takes them (:func:`startrack.solver._lost_in_space.identify`), else measured
    here."""
    rotation = check.rotation
    if check.residual_arcsec is not None and check.obs_vectors is obs.vectors:
        obs_index, cat_index, residuals = (check.obs_index, check.cat_index,
                                           check.residual_arcsec)
    else:
        order = np.argsort(check.obs_index)
        obs_index, cat_index = check.obs_index[order], check.cat_index[order]
        residuals = residuals_arcsec(rotation, obs, obs_index, database.vectors[cat_index])
    return Solution(True, method, rotation, obs_index, cat_index, residuals,
                    check.false_probability, diag, (time.perf_counter() - t0) * 1000.0)


def search_window(matcher: QuadMatcher, x, y, camera: Camera, window: Pass,
                  sigma_px: float, database: StarDatabase, config: VerifyConfig,
                  diag: MatchDiagnostics, seen: set, deadline: Deadline = NO_DEADLINE,
                  given: Camera | None = None, flux: np.ndarray | None = None):
    """The first quad hypothesis of ``window`` (a focal-length range, a pattern level, and
    either its one strong candidate or all of them ranked) that passes
    :func:`verify_fitted` against ``database``: (verification, camera, obs) or None.
    ``given``: the nominal camera, if any; a hypothesis whose own stars put the focal
    length within :data:`GIVEN_FIRST_WITHIN` of it is verified through it first, and that
    answer stands where the matched stars do not reject the camera
    (:func:`~startrack.solver._fov_given.through_given`). ``flux``: the stars' measured
    fluxes (None: not measured), weighed by the final labelling. Raises
    :class:`SearchTimeout` when ``deadline`` passes first."""
    n_cat = len(database.vectors)
    _check(deadline)
    tried = 0
    f_lo, f_hi = window.f_lo, window.f_hi
    if window.strong_only:
        strong = matcher.strong(x, y, camera, f_lo, f_hi, diag, database, window.deeper)
        candidates = [] if strong is None else [strong]
    else:
        candidates = matcher.scaled(x, y, camera, f_lo, f_hi, diag, database, window.deeper)
    for sh in candidates:
        if sh.confirmed < MIN_CONFIRMED:
            break  # best first: no later candidate has more support
        hyp = sh.hypothesis
        rows = hyp.cat_index.tolist()
        key = tuple(sorted(zip(hyp.obs_index.tolist(), rows, strict=True)))
        if key in seen or max(rows) >= n_cat:
            continue
        _check(deadline)
        seen.add(key)
        diag.hypotheses += 1
        tried += 1
        guess = _fitted_guess(sh, x, y, camera, sigma_px, database, config, flux)
        through = given is not None and abs(guess.f_px / given.f_px - 1.0) <= GIVEN_FIRST_WITHIN

        def verified(weighed, hyp=hyp, guess=guess, through=through):
            found = (through_given(hyp, x, y, given, sigma_px, database, config, weighed)
                     if through else None)
            return found or verify_fitted(hyp, x, y, guess, sigma_px, database, config,
                                          flux=weighed)

        found = weighed_first(verified, flux, len(x))
        if found is not None:
            return found
        if tried >= MAX_VERIFY:
            break
    return None


def _fitted_guess(sh: ScaledHypothesis, x, y, camera: Camera, sigma_px: float,
                  database: StarDatabase, config: VerifyConfig, flux=None) -> Camera:
    """The camera with the focal length fitted to the hypothesis' own four stars (from
    the pattern's focal length; that one where the fit fails), in one compiled call."""
    h = sh.hypothesis
    rounds = rounds_for(x, y, camera, sigma_px, database, config, flux)
    return camera.with_focal(rounds.pattern_focal(
        np.ascontiguousarray(h.obs_index, dtype=np.int64),
        np.ascontiguousarray(h.cat_index, dtype=np.int64), sh.f_px))


@dataclass(frozen=True)
class FovResult:
    """What a search found (or not): the solution, the fitted camera it holds for, the
    observation through that camera, and the catalog its rows index."""

    solution: Solution
    camera: Camera
    obs: Observation
    catalog: Catalog
    match_radius_px: float

    def plus_ms(self, ms: float) -> FovResult:
        """This find with ``ms`` more spent on it (a stage before it that gave no answer)."""
        return FovResult(dataclasses.replace(self.solution,
                                             identify_ms=self.solution.identify_ms + ms),
                         self.camera, self.obs, self.catalog, self.match_radius_px)


def _result(found, catalog: Catalog, method: str, diag: MatchDiagnostics, t0: float,
            config: VerifyConfig, database: StarDatabase, reason: str = "no_match"):
    """The :class:`FovResult` of a verified find (or of nothing: ``found[0]`` None)."""
    check, camera, obs = found
    if check is None:
        sol = Solution(False, method, diagnostics=diag, reason=reason,
                       identify_ms=(time.perf_counter() - t0) * 1000.0)
    else:
        sol = _solution(check, obs, database, method, diag, t0)
    return FovResult(sol, camera, obs, catalog, config.radius_px(obs))


def solve_approximate(ident, x: np.ndarray, y: np.ndarray, tolerance: float,
                      deadline: Deadline = NO_DEADLINE,
                      flux: np.ndarray | None = None) -> FovResult:
    """Solve the stars at pixels ``x``, ``y`` (measured fluxes ``flux``, if any) with ``ident`` (an
    :class:`startrack.solver._identifier.Identifier` of the quad matcher) whose camera's focal
    length is nominal: the true FOV may be ``tolerance`` off either way; not solved with
    reason "timeout" if ``deadline`` passes first."""
    t0 = time.perf_counter()
    cam, db, config, quad = ident.camera, ident.database, ident.verify_config, ident.matcher
    diag, seen = MatchDiagnostics(), set()

    def unsolved(reason: str) -> FovResult:
        obs = Observation.from_pixels(x, y, cam, ident.sigma_px)
        return _result((None, cam, obs), ident.catalog, quad.name, diag, t0, config, db,
                       reason=reason)

    if len(x) < 3:
        return unsolved("too_few_stars")
    try:
        for window in passes(*focal_range(cam, tolerance), cam.f_px):
            found = search_window(quad, x, y, cam, window, ident.sigma_px, db, config, diag,
                                  seen, deadline, given=cam, flux=flux)
            if found is not None:
                found = keep_given(found, cam, ident.sigma_px, db, config)
                return _result(found, ident.catalog, quad.name, diag, t0, config, db)
    except SearchTimeout:
        return unsolved("timeout")
    return unsolved("no_match")


#: a search whose process grew by more than this since it started gives back the table
#: pages it swept and its freed heap after a window (startrack.io.shed_memory): a deep
#: sky's narrow levels would all stay resident, GBs by the end of a search that finds
#: nothing. Growth, not size: a process that holds much already (a bench, a compare) and
#: searches small tables would otherwise read them back after every window.
SHED_GROWTH_BYTES = 768 << 20


class BlindSolver:
    """The blind search over :data:`BLIND_FOV_RANGE` for one (uncut) catalog; ``sigma_px``
    the centroid error of the stars it solves next (a pipeline sets it per input)."""

    def __init__(self, catalog: Catalog, sky, sigma_px: float,
                 verify_config: VerifyConfig | None = None,
                 fov_range: tuple[float, float] = BLIND_FOV_RANGE) -> None:
        self.catalog, self.sky, self.sigma_px = catalog, sky, float(sigma_px)
        self.config = verify_config or VerifyConfig()
        self.fov_range = fov_range
        self.matcher = QuadMatcher(StarDatabase(catalog, Camera.from_fov(1024, 1024, 10.0)))
        self._databases: dict[int, StarDatabase] = {}
        self._limits: dict[float, float | None] = {}

    def database_for(self, camera: Camera) -> StarDatabase:
        """The catalog cut by the default magnitude rule for ``camera``; rows are a prefix
        of the whole catalog (brightest first), so row numbers agree."""
        if camera.f_px not in self._limits:
            spec = resolve_sky(dataclasses.replace(self.sky, mag_limit=None), camera)
            self._limits[camera.f_px] = spec.mag_limit
        limit = self._limits[camera.f_px]
        n = len(self.catalog) if limit is None else int(
            np.searchsorted(self.catalog.mag, limit, side="right"))
        if n not in self._databases:
            # Memory stays bounded: a deep catalog's cut for a narrow window holds GBs of
            # tables, and every window has its own cut. Their tables are in the disk cache,
            # so a cut evicted here is reloaded, not rebuilt.
            while len(self._databases) >= KEEP_DATABASES:
                self._databases.pop(next(iter(self._databases)))
            cut = StarDatabase(self.catalog.head(n), camera)
            # the whole catalog's cone index, cut: sorting a deep catalog per window took
            # most of a blind search's time
            cut.__dict__["cone_index"] = self._cones().cut(n)
            self._databases[n] = cut
        return self._databases[n]

    def _cones(self) -> CutCones:
        """The cone indexes of the catalog's cuts, from its whole index (cone_index_of),
        held by the catalog: every blind search of it indexes the same stars."""
        cones = self.catalog.__dict__.get("_cut_cones")
        if cones is None:
            cones = self.catalog.__dict__["_cut_cones"] = CutCones(
                cone_index_of(self.catalog), KEEP_CONE_BYTES)
        return cones

    def solve(self, x: np.ndarray, y: np.ndarray, size: tuple[int, int],
              deadline: Deadline = NO_DEADLINE, camera: Camera | None = None,
              tolerance: float = DEFAULT_FOV_TOLERANCE,
              held_bytes: int | None = None, flux: np.ndarray | None = None) -> FovResult:
        """Search every window (from the nominal's outward with ``camera``, else widest
        field first); the first verified find wins. Not
        solved, with reason "timeout", if ``deadline`` passes first. With ``camera`` (a
        nominal focal length) only the focal lengths within ``tolerance`` of it are
        searched, through that camera (its centre and lens model). ``held_bytes``: the
        resident memory its growth is counted from (:data:`SHED_GROWTH_BYTES`; None: now),
        one baseline for the skies one look searches in turn. ``flux``: the stars'
        measured fluxes, if any."""
        t0 = time.perf_counter()
        base = camera or Camera.from_fov(size[0], size[1], math.sqrt(np.prod(self.fov_range)))
        # widened by MARGIN, as a nominal range is: a camera at the very end of the range
        # (a 1 deg field) has its patterns' focal lengths on both sides of that end
        f_lo, f_hi = focal_range(camera, tolerance) if camera else (
            f_of_fov(size[0], max(self.fov_range) * (1.0 + MARGIN)),
            f_of_fov(size[0], min(self.fov_range) / (1.0 + MARGIN)))
        diag, seen = MatchDiagnostics(), set()
        held = (resident_bytes() if held_bytes is None else held_bytes) or 0
        db = self.database_for(base)
        reason = "no_match" if len(x) >= 3 else "too_few_stars"
        try:
            for window in passes(f_lo, f_hi, camera and camera.f_px) if len(x) >= 3 else []:
                _check(deadline)  # before the window's tables are built
                db = self.database_for(dataclasses.replace(
                    base, f_px=math.sqrt(window.f_lo * window.f_hi)))
                found = search_window(self.matcher, x, y, base, window, self.sigma_px, db,
                                      self.config, diag, seen, deadline, given=camera,
                                      flux=flux)
                if found is None:
                    shed_memory(held + SHED_GROWTH_BYTES)
                    continue
                if camera is not None:
                    found = keep_given(found, camera, self.sigma_px, db, self.config)
                return _result(found, self.catalog, self.matcher.name, diag, t0,
                               self.config, db)
        except SearchTimeout:
            reason = "timeout"
        obs = Observation.from_pixels(x, y, base, self.sigma_px)
        return _result((None, base, obs), self.catalog, self.matcher.name, diag, t0,
                       self.config, db, reason=reason)
