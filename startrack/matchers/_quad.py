"""Scale-free four-star patterns: the matcher for an approximate or unknown field of view.

Every four of the brightest observed stars that fit a level of
:mod:`startrack.database._quads` make a pattern; each pattern's key (its edge
ratios) is looked up with a tolerance in the level nearest the assumed field of view,
and every catalog pattern whose six edges agree (in the best of the 24 star orders)
becomes a hypothesis with the focal length that its size implies. The focal length is
only assumed to within a window, so :meth:`QuadMatcher.scaled` serves an approximate
FOV (a window about the nominal value) and a blind search (:mod:`startrack.solver._fov_search`
sweeps
the window over the whole range). Work is bounded: at most ``IMAGE_STARS`` stars and
``MAX_CANDIDATES`` candidates per window.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from startrack._core.matchers.quad import (
    QuadRules,
    QuadTable,
    QuadWindow,
    first_confirmed,
    match_window,
)
from startrack._core.matchers.quad_confirm import Confirmer, ConfirmRules
from startrack._core.matchers.quad_confirm import confirmations as confirm_kernel
from startrack.camera import Camera
from startrack.database import (
    BIN,
    EDGES,
    LEVEL_STEP,
    MAX_PATTERN_SIZE,
    NBINS,
    PATTERN_SIZE,
    RATIO_STEPS,
    QuadLevel,
    StarDatabase,
    level_for,
    level_stars,
    quad_level,
)
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import Matcher, register

IMAGE_STARS = 16  # brightest observed stars whose every four make a pattern
#: an image star's patterns reach its this many nearest image stars (the catalog's reach
#: its ``K_NEAREST`` nearest: more, as the image also holds stars the catalog lacks)
IMAGE_NEAREST = 10
RATIO_TOLERANCE = 0.012  # largest error of one edge ratio (key lookup and edge test)
MAX_CANDIDATES = 4000  # best by edge agreement, before the confirmation count
CHECK_STARS = 24  # brightest observed stars counted against the catalog per candidate
#: a candidate with this many confirmations is verified before the others are ranked
#: (a false pattern seldom has more than two)
STRONG_CONFIRMED = 6
CHECK_RADIUS_PX = 6.0  # generous: the focal length is known only from the pattern
GUESSES_KEPT = 64  # focal-length windows whose camera and level a matcher remembers
#: for each of the 24 star orders, the catalog edge that each image edge corresponds to
_EDGE_INDEX = {tuple(e): k for k, e in enumerate(EDGES.tolist())}
PERM_EDGES = np.array([[_EDGE_INDEX[tuple(sorted((p[a], p[b])))] for a, b in EDGES]
                       for p in itertools.permutations(range(4))])
PERMS = np.array(list(itertools.permutations(range(4))))
RULES = QuadRules(tolerance=RATIO_TOLERANCE, bin=BIN, nbins=NBINS,
                  near=RATIO_TOLERANCE + 0.5 / RATIO_STEPS, ratio_unit=1.0 / RATIO_STEPS,
                  max_candidates=MAX_CANDIDATES, image_stars=IMAGE_STARS,
                  image_nearest=IMAGE_NEAREST, edges=EDGES, perms=PERMS,
                  perm_edges=PERM_EDGES)


@dataclass(frozen=True)
class ScaledHypothesis:
    """A hypothesis with the focal length (pixels) its pattern's size implies."""

    hypothesis: Hypothesis
    f_px: float
    error: float  # largest edge-ratio disagreement
    confirmed: int = 0  # other bright stars near a catalog star (:func:`confirmations`)


def compiled_table(table: QuadLevel) -> QuadTable:
    """``table`` as the compiled search reads it (built once per level): its keys are
    bucketed by their three highest ratio digits."""
    compiled = table.__dict__.get("_compiled")
    if compiled is None:
        compiled = table.__dict__["_compiled"] = QuadTable(table.keys, table.quads,
                                                           table.ratios, NBINS)
    return compiled


def match_patterns(vectors: np.ndarray, table: QuadLevel, cat_vectors: np.ndarray,
                   slack: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Observed and catalog patterns that agree (the image's patterns: every four of the
    ``IMAGE_STARS`` brightest stars whose edges fit the level; ``slack``: how much larger
    than assumed the scale may be): (obs rows M x 4, catalog rows M x 4 in
    matching order, scale = observed / catalog size, error), best first (smallest error,
    then image pattern and table row). Each pattern's key is looked up with the ratio
    tolerance (the 32 bin combinations it may fall in); sorting moves no ratio by more
    than the largest edge error, so a test on the table's stored sorted ratios drops most
    candidates before their stars are read (:func:`startrack._core.matchers.quad.match_window`)."""
    size = math.radians(table.level_deg) * slack
    found = match_window(compiled_table(table), RULES, np.ascontiguousarray(cat_vectors),
                         np.ascontiguousarray(vectors, np.float64), PATTERN_SIZE * size,
                         MAX_PATTERN_SIZE * size)
    return found.obs, found.cat, found.scale, found.error


CONFIRM_RULES = ConfirmRules(radius_px=CHECK_RADIUS_PX, check_stars=CHECK_STARS)


def confirmations(x: np.ndarray, y: np.ndarray, camera: Camera, obs_q: np.ndarray,
                  cat_q: np.ndarray, f: np.ndarray, check: StarDatabase) -> np.ndarray:
    """For each candidate, how many of the ``CHECK_STARS`` brightest stars outside its
    pattern lie within ``CHECK_RADIUS_PX`` of a catalog star of ``check`` at the attitude
    the pattern gives (pinhole, focal length ``f``); -1 for a candidate naming a row
    ``check`` lacks: a cheap first look, in one compiled call
    (:func:`startrack._core.matchers.quad_confirm.confirmations`), that ranks candidates for
    verification."""
    return confirm_kernel(_confirmer(x, y, camera, check), np.ascontiguousarray(obs_q, np.int64),
                          np.ascontiguousarray(cat_q, np.int64),
                          np.ascontiguousarray(f, np.float64))


def _confirmer(x: np.ndarray, y: np.ndarray, camera: Camera, check: StarDatabase) -> Confirmer:
    return Confirmer(CONFIRM_RULES, np.ascontiguousarray(x, np.float64),
                     np.ascontiguousarray(y, np.float64), float(camera.cx), float(camera.cy),
                     check.cone_index.table)


@register
class QuadMatcher(Matcher):
    """Four-star patterns keyed on edge ratios; the scale follows from the match."""

    name = "quad"
    description = "scale-free 4-star patterns keyed on sorted edge ratios (tetra3's idea)"
    tables = ()
    scale_free = True
    #: the focal-length window of :meth:`hypotheses` (a known camera): +-2%
    tolerance = 0.02

    def prepare(self) -> None:
        self.level(self.database.camera.fov_deg)

    def level(self, fov_deg: float) -> QuadLevel:
        """The pattern table of the level nearest ``fov_deg`` (built once)."""
        levels = self.__dict__.setdefault("_levels", {})
        key = level_for(fov_deg)
        if key not in levels:
            levels[key] = quad_level(self.database.catalog, key)
        return levels[key]

    def deeper_levels(self, fov_deg: float) -> int:
        """How many levels below the nearest one :meth:`scaled` may search for a field of
        ``fov_deg``: one, unless the nearest level's pattern stars are already the whole
        catalog (a deeper level would hold no other star)."""
        return int(level_stars(level_for(fov_deg)) < len(self.database.vectors))

    def _guess(self, camera: Camera, f_mid: float,
               deeper: int) -> tuple[Camera, QuadLevel | None]:
        """``camera`` with focal length ``f_mid`` and the level a window searches there
        (None beyond :meth:`deeper_levels`), remembered for the last few windows: with a
        nominal field of view every frame asks for the same one."""
        guesses = self.__dict__.setdefault("_guesses", {})
        key = (id(camera), f_mid, deeper)
        known = guesses.get(key)
        if known is not None and known[0] is camera:  # held, so its id is not reused
            return known[1], known[2]
        guess = camera.with_focal(f_mid)
        level = (None if deeper > self.deeper_levels(guess.fov_deg)
                 else self.level(guess.fov_deg / LEVEL_STEP ** deeper))
        if len(guesses) >= GUESSES_KEPT:
            guesses.clear()
        guesses[key] = (camera, guess, level)
        return guess, level

    def _window(self, x: np.ndarray, y: np.ndarray, camera: Camera, f_lo: float,
                f_hi: float, deeper: int) -> _Window | None:
        f_mid = math.sqrt(f_lo * f_hi)
        guess, level = self._guess(camera, f_mid, deeper)
        if level is None:
            return None
        # only the brightest IMAGE_STARS make patterns
        vectors = guess.pixel_to_vector(x[:IMAGE_STARS], y[:IMAGE_STARS])
        return _Window(f_mid, vectors, level, math.sqrt(f_hi / f_lo) * 1.02)

    def scaled(self, x: np.ndarray, y: np.ndarray, camera: Camera, f_lo: float, f_hi: float,
               diag: MatchDiagnostics, check: StarDatabase | None = None, deeper: int = 0,
               ) -> list[ScaledHypothesis]:
        """Hypotheses for the stars at pixels ``x``, ``y`` (brightest first) seen through
        ``camera`` with its focal length anywhere in [f_lo, f_hi]; best first: most of
        the brightest other stars confirmed against ``check`` (default: this matcher's
        database) at each pattern's own attitude and scale, then closest edges. ``deeper``:
        the patterns of the level that many steps narrower than the nearest (fainter
        pattern stars: a sparse patch of sky holds too few of the nearest level's; none
        beyond :meth:`deeper_levels`)."""
        w = self._window(x, y, camera, f_lo, f_hi, deeper)
        if w is None:
            return []
        obs_q, cat_q, scale, error = match_patterns(w.vectors, w.level, self.database.vectors,
                                                    w.slack)
        f = w.f_mid * scale
        keep = (f >= f_lo) & (f <= f_hi)
        obs_q, cat_q, f, error = obs_q[keep], cat_q[keep], f[keep], error[keep]
        diag.candidates += len(obs_q)
        if len(obs_q) == 0:
            return []
        count = confirmations(x, y, camera, obs_q, cat_q, f, check or self.database)
        order = np.lexsort((error, -count))
        return [ScaledHypothesis(Hypothesis(obs_q[k], cat_q[k]), float(f[k]), float(error[k]),
                                 int(count[k])) for k in order]

    def strong(self, x: np.ndarray, y: np.ndarray, camera: Camera, f_lo: float, f_hi: float,
               diag: MatchDiagnostics, check: StarDatabase | None = None, deeper: int = 0,
               ) -> ScaledHypothesis | None:
        """The first candidate of :meth:`scaled`'s window with at least
        ``STRONG_CONFIRMED`` confirmations, the patterns of the brightest stars first,
        found without ranking the others (one compiled call,
        :func:`startrack._core.matchers.quad.first_confirmed`); None when no candidate is that
        strong (then :meth:`scaled` ranks them all)."""
        w = self._window(x, y, camera, f_lo, f_hi, deeper)
        if w is None:
            return None
        size = math.radians(w.level.level_deg) * w.slack
        window = QuadWindow(max_edge=PATTERN_SIZE * size,
                            sparse_edge=MAX_PATTERN_SIZE * size, f_mid=w.f_mid, f_lo=f_lo,
                            f_hi=f_hi, min_count=STRONG_CONFIRMED)
        found = first_confirmed(compiled_table(w.level), RULES, window,
                                np.ascontiguousarray(self.database.vectors),
                                np.ascontiguousarray(w.vectors, np.float64),
                                _confirmer(x, y, camera, check or self.database))
        if found is None:
            return None
        diag.candidates += 1
        return ScaledHypothesis(Hypothesis(found.obs, found.cat), found.f_px, found.error,
                                int(found.confirmed))

    def candidates(self, x: np.ndarray, y: np.ndarray, camera: Camera, f_lo: float,
                   f_hi: float, diag: MatchDiagnostics, check: StarDatabase | None = None,
                   deeper: int = 0) -> Iterator[ScaledHypothesis]:
        """:meth:`strong`'s candidate, then (only when the caller asks for more)
        :meth:`scaled`'s ranking, which may hold that candidate again."""
        first = self.strong(x, y, camera, f_lo, f_hi, diag, check, deeper)
        if first is not None:
            yield first
        yield from self.scaled(x, y, camera, f_lo, f_hi, diag, check, deeper)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        f = obs.camera.f_px
        for h in self.candidates(obs.x, obs.y, obs.camera, f / (1 + self.tolerance),
                                 f * (1 + self.tolerance), diag):
            yield h.hypothesis


@dataclass(slots=True)  # not frozen: made per call, and a frozen one is slower to make
class _Window:
    """One focal-length window as the image sees it: the focal length its vectors were
    made with, those vectors, the pattern level searched, and how much larger than
    assumed the scale may be."""

    f_mid: float
    vectors: np.ndarray
    level: QuadLevel
    slack: float

__all__ = [
    "CHECK_RADIUS_PX", "CHECK_STARS", "CONFIRM_RULES", "IMAGE_NEAREST", "IMAGE_STARS",
    "MAX_CANDIDATES", "PERMS", "PERM_EDGES", "QuadMatcher", "RATIO_TOLERANCE",
    "STRONG_CONFIRMED", "ScaledHypothesis", "confirmations", "match_patterns",
]
