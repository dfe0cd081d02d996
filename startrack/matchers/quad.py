"""Scale-free four-star patterns: the matcher for an approximate or unknown field of view.

The brightest observed stars, thinned as the catalog is (:mod:`startrack.database.quads`),
make four-star patterns with their nearest neighbours; each pattern's key (its edge
ratios) is looked up with a tolerance in the level nearest the assumed field of view,
and every catalog pattern whose six edges agree (in the best of the 24 star orders)
becomes a hypothesis with the focal length that its size implies. The focal length is
only assumed to within a window, so :meth:`QuadMatcher.scaled` serves an approximate
FOV (a window about the nominal value) and a blind search (:mod:`startrack.fov` sweeps
the window over the whole range). Work is bounded: at most ``POOL`` stars,
``CENTRES`` pattern centres and ``MAX_CANDIDATES`` candidates per window.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from startrack.camera import Camera
from startrack.database import quads as Q
from startrack.matchers.base import Matcher, register
from startrack.types import Hypothesis, MatchDiagnostics, Observation

POOL = 40  # brightest observed stars considered
CENTRES = 10  # brightest thinned stars that centre patterns
IMAGE_NEIGHBOURS = 6  # one more than the catalog's: a missing or extra star is tolerated
RATIO_TOLERANCE = 0.012  # largest error of one edge ratio (key lookup and edge test)
MAX_CANDIDATES = 400
#: for each of the 24 star orders, the catalog edge that each image edge corresponds to
_EDGE_INDEX = {tuple(e): k for k, e in enumerate(Q.EDGES.tolist())}
PERM_EDGES = np.array([[_EDGE_INDEX[tuple(sorted((p[a], p[b])))] for a, b in Q.EDGES]
                       for p in itertools.permutations(range(4))])
PERMS = np.array(list(itertools.permutations(range(4))))


@dataclass(frozen=True)
class ScaledHypothesis:
    """A hypothesis with the focal length (pixels) its pattern's size implies."""

    hypothesis: Hypothesis
    f_px: float
    error: float  # largest edge-ratio disagreement


def _query_keys(r: np.ndarray) -> np.ndarray:
    """The (M x 32) keys of every bin combination within the ratio tolerance."""
    lo = np.clip(((r - RATIO_TOLERANCE) / Q.BIN).astype(np.int64), 0, Q.NBINS - 1)
    hi = np.clip(((r + RATIO_TOLERANCE) / Q.BIN).astype(np.int64), 0, Q.NBINS - 1)
    pick = np.array(list(itertools.product((0, 1), repeat=5)))  # 32 x 5
    q = np.where(pick[None, :, :] == 0, lo[:, None, :], hi[:, None, :])
    return (q * (Q.NBINS ** np.arange(5))).sum(axis=2)


def image_patterns(vectors: np.ndarray, level_deg: float,
                   slack: float) -> tuple[np.ndarray, np.ndarray]:
    """Observed patterns (M x 4 observation rows) and their six edges, for one level.

    ``slack`` is how much larger than assumed the scale may be (edges may look longer)."""
    level = math.radians(level_deg)
    pool = np.arange(min(len(vectors), POOL))
    kept = pool[Q.thin(vectors[pool], Q.SEPARATION * level / slack)]
    centres = np.arange(min(len(kept), CENTRES))
    quads = Q.neighbour_quads(vectors[kept], centres, Q.PATTERN_SIZE * level * slack,
                              IMAGE_NEIGHBOURS)
    quads = kept[quads]
    return quads, Q.edge_angles(vectors, quads)


def match_patterns(vectors: np.ndarray, table: Q.QuadLevel, cat_vectors: np.ndarray,
                   slack: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Observed and catalog patterns that agree: (obs rows M x 4, catalog rows M x 4 in
    matching order, scale = observed / catalog size, error), best first."""
    quads, edges = image_patterns(vectors, table.level_deg, slack)
    empty = (np.zeros((0, 4), np.int64), np.zeros((0, 4), np.int64), np.zeros(0), np.zeros(0))
    if len(quads) == 0 or len(table) == 0:
        return empty
    r, largest = Q.ratios(edges)
    qi, rows = table.lookup(_query_keys(r).ravel())
    qi //= 32
    pairs = np.unique(np.stack([qi, rows], axis=1), axis=0)
    if len(pairs) == 0:
        return empty
    qi, rows = pairs[:, 0], pairs[:, 1]
    img = edges[qi] / largest[qi, None]  # (P, 6)
    cat_quads = table.quads[rows].astype(np.int64)
    cat_edges = Q.edge_angles(cat_vectors, cat_quads)
    cat = cat_edges / cat_edges.max(axis=1, keepdims=True)
    err = np.abs(img[:, None, :] - cat[:, PERM_EDGES]).max(axis=2)  # (P, 24)
    best = np.argmin(err, axis=1)
    error = err[np.arange(len(qi)), best]
    good = np.flatnonzero(error <= RATIO_TOLERANCE)
    good = good[np.argsort(error[good], kind="stable")][:MAX_CANDIDATES]
    perm = PERMS[best[good]]
    cat_ordered = np.take_along_axis(cat_quads[good], perm, axis=1)
    scale = edges[qi[good]].sum(axis=1) / np.take_along_axis(
        cat_edges[good], PERM_EDGES[best[good]], axis=1).sum(axis=1)
    return quads[qi[good]], cat_ordered, scale, error[good]


@register
class QuadMatcher(Matcher):
    """Four-star patterns keyed on edge ratios; the scale follows from the match."""

    name = "quad"
    description = "scale-free 4-star patterns keyed on sorted edge ratios (tetra3's idea)"
    tables = ()
    #: the focal-length window of :meth:`hypotheses` (a known camera): +-2%
    tolerance = 0.02

    def prepare(self) -> None:
        self.level(self.database.camera.fov_deg)

    def level(self, fov_deg: float) -> Q.QuadLevel:
        """The pattern table of the level nearest ``fov_deg`` (built once)."""
        levels = self.__dict__.setdefault("_levels", {})
        key = Q.level_for(fov_deg)
        if key not in levels:
            levels[key] = Q.quad_level(self.database.catalog, key)
        return levels[key]

    def scaled(self, x: np.ndarray, y: np.ndarray, camera: Camera, f_lo: float, f_hi: float,
               diag: MatchDiagnostics) -> list[ScaledHypothesis]:
        """Hypotheses for the stars at pixels ``x``, ``y`` (brightest first) seen through
        ``camera`` with its focal length anywhere in [f_lo, f_hi], best first."""
        f_mid = math.sqrt(f_lo * f_hi)
        guess = dataclasses.replace(camera, f_px=f_mid)
        vectors = guess.pixel_to_vector(x, y)
        slack = math.sqrt(f_hi / f_lo) * 1.02
        obs_q, cat_q, scale, error = match_patterns(
            vectors, self.level(guess.fov_deg), self.database.vectors, slack)
        diag.candidates += len(obs_q)
        f = f_mid * scale
        keep = (f >= f_lo) & (f <= f_hi)
        return [ScaledHypothesis(Hypothesis(o, c), float(fk), float(e))
                for o, c, fk, e in zip(obs_q[keep], cat_q[keep], f[keep], error[keep],
                                       strict=True)]

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
        f = obs.camera.f_px
        for h in self.scaled(obs.x, obs.y, obs.camera, f / (1 + self.tolerance),
                             f * (1 + self.tolerance), diag):
            yield h.hypothesis
