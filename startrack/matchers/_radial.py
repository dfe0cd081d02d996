"""Radial features, then triangles (the improved triangle star identification with radial
features, Rocket Force University of Engineering): a shortlist per star, then
side-side-side.

Each of the brightest observed stars gets a radial feature from all the other observed
stars; the catalog stars whose features share at least ``frac`` of its rings form its
shortlist. The classic triangle test (three inter-star angles within the noise window)
then runs only over the shortlists: m1 * m2 * m3 candidate triangles instead of every
catalog triangle. A catalog star near a frame edge sees neighbours outside the frame and
an observed star near the edge misses some; the score counts only the rings the observed
star occupies, so extra catalog rings cost nothing.

Variants (constructor keywords; registered names in brackets): ``rings="noise"`` sets the
ring width from each frame's stated noise instead of ``noise_px`` [radial_noise];
``rings="paper"``, ``threshold="all"``, ``edge_tolerance=False`` are the paper's text: R
and dr from the observed and the navigation stars (equation 3), l >= 3/4 Nq counting every
ring (equation 4), a neighbour's ring taken as measured [radial_paper];
``rings="observed"`` takes R and dr from the observed stars alone; ``patch_deg`` restricts
the catalog to a known sky patch around ``patch_center`` (set per frame by the caller), as
the paper's experiment did [radial_patch, radial_paper_patch]; ``prefilter=False`` drops
the radial shortlist, so the side-side-side test runs over every catalog star (through the
pair table) or every star of the patch: the paper's baseline [sss, sss_patch], with our
mirror check, fourth-star ordering and ``max_matches``; ``literal=True`` is equation 5
alone: every catalog triangle whose three sides lie within eps of the observed ones, in
catalog order, no mirror check, no fourth star, no cap [sss_paper, sss_paper_patch].
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import combinations

import numpy as np

from startrack.database import (
    RadialTable,
    StarDatabase,
    build_radial_arrays,
    observed_masks,
    radial_table_from_arrays,
)
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import Matcher, MatcherConfig, register, register_variant
from startrack.matchers._shared.geometry import angle_table, handedness, triple_products
from startrack.matchers._shared.radial_rings import (
    catalog_range,
    dense_triangles,
    field_rings,
    pair_triangles,
    paper_rings,
    separation_range,
)

RINGS = ("fixed", "noise", "observed", "paper")
THRESHOLDS = ("occupied", "all")
#: radius (deg) of the known sky patch of the patch variants: the 4 x 4 deg field's
#: half-diagonal (2.83 deg) and a margin for a pointing known to about a degree
PATCH_DEG = 4.0
#: the __all__ of the ring helpers this module re-exports for its callers
__all__ = ["RadialMatcher", "field_rings", "pair_triangles"]


@register
class RadialMatcher(Matcher):
    """Parameters: ``radius_deg`` (R; default: the radius holding ``target_neighbours``
    catalog stars on average, at most the image diagonal), ``ring_width_deg`` (dr;
    default: ``ring_sigma`` angle-noise sigmas at ``noise_px`` centroid noise, so that a
    noise window spans at most two rings), ``frac`` (share of the observed rings a catalog
    star must have), ``cap`` (longest shortlist), ``min_rings`` (an observed star with
    fewer rings is not distinctive enough for a shortlist), ``max_matches`` (catalog
    triangles tried per observed triangle), ``rings`` (:data:`RINGS`: how R and dr are
    chosen), ``threshold`` ("occupied": l >= frac of the rings the observed star occupies;
    "all": l >= frac of every ring, the paper's 3/4 Nq), ``edge_tolerance`` (a neighbour
    within the angle tolerance of a ring edge may fall in either ring; False: the paper's
    bits as measured), ``prefilter`` and ``patch_deg`` (see the module)."""

    name = "radial"
    description = ("radial-feature shortlists, then side-side-side triangles (the "
                   "improved triangle paper)")

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 radius_deg: float | None = None, ring_width_deg: float | None = None,
                 target_neighbours: float = 20.0, noise_px: float = 0.3,
                 ring_sigma: float | None = None, frac: float = 0.75, cap: int = 10,
                 min_rings: int = 4, max_matches: int = 8, rings: str = "fixed",
                 prefilter: bool = True, patch_deg: float | None = None,
                 threshold: str = "occupied", edge_tolerance: bool = True,
                 literal: bool = False) -> None:
        super().__init__(database, config)
        self.literal = bool(literal)  # equation 5 alone (see the module)
        if rings not in RINGS:
            raise ValueError(f"rings must be one of {', '.join(RINGS)}, got {rings!r}")
        if threshold not in THRESHOLDS:
            raise ValueError(f"threshold must be one of {', '.join(THRESHOLDS)}, "
                             f"got {threshold!r}")
        self.rings, self.prefilter = rings, bool(prefilter)
        self.threshold, self.edge_tolerance = threshold, bool(edge_tolerance)
        self.patch_rad = None if patch_deg is None else math.radians(patch_deg)
        self.patch_center: np.ndarray | None = None  # ICRS unit vector, set per frame
        if not 0.0 < frac <= 1.0:
            raise ValueError("frac must be in (0, 1]")
        if cap < 1 or max_matches < 1:
            raise ValueError("cap and max_matches must be positive")
        n_cat = max(len(database.vectors), 1)
        if radius_deg is None:
            # n stars on the sphere: pi R^2 * n / (4 pi) neighbours within a small R.
            radius = math.sqrt(4.0 * target_neighbours / n_cat)
        else:
            radius = math.radians(radius_deg)
        self.radius_rad = min(radius, database.max_angle_rad)
        if ring_width_deg is None:
            sigmas = 2.0 * self.config.tolerance_sigma if ring_sigma is None else ring_sigma
            sigma_angle = math.sqrt(2.0) * noise_px / database.camera.f_px
            width = max(sigmas * sigma_angle, 2.0 * self.config.min_tolerance_rad)
        else:
            width = math.radians(ring_width_deg)
        self.ring_width_rad = width
        self._ring_sigmas = 2.0 * self.config.tolerance_sigma if ring_sigma is None \
            else ring_sigma
        self.frac, self.cap, self.min_rings, self.max_matches = frac, cap, min_rings, max_matches
        self._table: RadialTable | None = None
        self._last: tuple = (None, None)  # (R, dr) and table of the last paper-ring frame

    def prepare(self) -> None:
        self._table = self.database.radial(self.radius_rad, self.ring_width_rad)

    @property
    def table(self) -> RadialTable:
        if self._table is None:
            self.prepare()
        return self._table

    def frame_table(self, obs: Observation) -> RadialTable:
        """The catalog's radial features for this frame's ring choice."""
        if self.rings == "fixed":
            return self.table
        if self.rings == "noise":
            width = max(self._ring_sigmas * math.sqrt(2.0) * obs.sigma_rad,
                        2.0 * self.config.min_tolerance_rad)
            return self.database.radial(self.radius_rad, width)
        radius, width = self.frame_rings(obs)
        key = (min(radius, self.database.max_angle_rad), width)
        if self._last[0] != key:  # the bench asks again for the same frame: keep one
            arrays = build_radial_arrays(self.database.pairs, len(self.database.vectors),
                                         *key)
            self._last = (key, radial_table_from_arrays(arrays, *key))
        return self._last[1]

    def frame_rings(self, obs: Observation) -> tuple[float, float]:
        """R and dr (radians) of a per-frame ring rule: "observed" from the observed stars
        alone, "paper" from them and the navigation stars (the patch's catalog stars when
        the patch is known, else every catalog star's tabled pairs)."""
        if self.rings == "observed":
            return field_rings(obs.vectors)
        patch = self.in_patch()
        if patch is None:
            navigation = catalog_range(self.database.pairs)
        else:
            navigation = separation_range(self.database.vectors[patch])
        return paper_rings(obs.vectors, navigation)

    def in_patch(self) -> np.ndarray | None:
        """Catalog rows inside the known sky patch (None: lost in space)."""
        if self.patch_rad is None or self.patch_center is None:
            return None
        cos = self.database.vectors @ np.asarray(self.patch_center, dtype=np.float64)
        return np.flatnonzero(cos >= math.cos(self.patch_rad))

    def shortlists(self, obs: Observation, n: int) -> list[np.ndarray]:
        """Catalog candidates of each of the first ``n`` observed stars, best first."""
        patch = self.in_patch()
        if not self.prefilter:
            every = np.arange(len(self.database.vectors)) if patch is None else patch
            return [every] * n
        table = self.frame_table(obs)
        tol = self.angle_tolerance(obs) if self.edge_tolerance else 0.0
        single, double, need = observed_masks(obs.vectors, np.arange(n), table.radius_rad,
                                              table.ring_width_rad, tol)
        lists = []
        for k in range(n):
            if need[k] < self.min_rings:
                lists.append(np.zeros(0, np.int64))
                continue
            # The paper's l >= 3/4 Nq counts every ring; ours the rings star k occupies.
            base = table.n_rings if self.threshold == "all" else int(need[k])
            rows, _ = table.shortlist(single[k], double[k], base, self.frac, self.cap,
                                      among=patch)
            lists.append(rows.astype(np.int64))
        return lists

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        n = min(len(obs), self.config.max_stars)
        if n < 3:
            return
        lists = self.shortlists(obs, n)
        sizes = np.array([len(s) for s in lists])
        diag.candidates += int(sizes.sum())
        diag.extra["mean_shortlist"] = float(sizes.mean())
        usable = [k for k in range(n) if sizes[k]]
        eps = self.angle_tolerance(obs)
        ov = obs.vectors[:n]
        obs_d = angle_table(ov, ov)
        cat = [self.database.vectors[s] for s in lists]
        for a, b, c in combinations(usable, 3):
            diag.pivots += 1
            found = self.triangle_matches(lists, cat, obs_d, (a, b, c), eps)
            if found is None:
                continue
            (ia, ib, ic), (ra, rb, rc) = found
            if self.literal:
                for tri in zip(ra, rb, rc, strict=True):
                    yield Hypothesis(np.array([a, b, c], np.int64), np.array(tri, np.int64))
                continue
            # Side-side-side cannot tell a triangle from its mirror image; a rotation can.
            keep = (ra != rb) & (rb != rc) & (ra != rc)
            triple = float(triple_products(ov[a], ov[b], ov[c]))
            if abs(triple) > 2.0 * eps * max(obs_d[a, b], obs_d[b, c], obs_d[a, c]):
                keep &= handedness(cat[a][ia], cat[b][ib], cat[c][ic]) == np.sign(triple)
            ra, rb, rc = ra[keep][: self.max_matches], rb[keep][: self.max_matches], \
                rc[keep][: self.max_matches]
            others = [e for e in usable if e not in (a, b, c)]
            with_fourth, plain = [], []
            for tri in zip(ra, rb, rc, strict=True):
                fourth = self._fourth(tri, (a, b, c), others, lists, cat, obs_d, eps)
                obs_i = [a, b, c] + ([fourth[0]] if fourth else [])
                cat_i = list(tri) + ([fourth[1]] if fourth else [])
                (with_fourth if fourth else plain).append(
                    Hypothesis(np.array(obs_i, np.int64), np.array(cat_i, np.int64)))
            yield from with_fourth
            yield from plain

    def triangle_matches(self, lists, cat, obs_d, stars, eps):
        """Side-side-side over the shortlists (or every catalog star): positions in the
        lists and catalog rows of the matching triangles, None when there is none."""
        a, b, c = stars
        if not self.prefilter and self.in_patch() is None:
            tri = pair_triangles(self.database.pairs, obs_d, a, b, c, eps)
            if len(tri) == 0:
                return None
            pos = (np.searchsorted(lists[a], tri[:, 0]), np.searchsorted(lists[b], tri[:, 1]),
                   np.searchsorted(lists[c], tri[:, 2]))
            return pos, (tri[:, 0], tri[:, 1], tri[:, 2])
        found = dense_triangles(cat[a], cat[b], cat[c], obs_d, stars, eps)
        if found is None:
            return None
        ia, ib, ic = found
        return (ia, ib, ic), (lists[a][ia], lists[b][ib], lists[c][ic])

    def _fourth(self, tri, stars, others, lists, cat, obs_d, eps) -> tuple[int, int] | None:
        """The first other observed star with exactly one shortlisted catalog star at the
        right angle from all three triangle stars."""
        tv = self.database.vectors[np.asarray(tri)]
        for e in others:
            d = angle_table(cat[e], tv)  # m_e x 3
            ok = np.all(np.abs(d - obs_d[e, list(stars)]) <= eps, axis=1)
            ok &= ~np.isin(lists[e], tri)
            if ok.sum() == 1:
                return e, int(lists[e][np.flatnonzero(ok)[0]])
        return None


LITERAL = {"rings": "paper", "threshold": "all", "edge_tolerance": False, "min_rings": 1,
           "cap": 50}
register_variant(RadialMatcher, "radial_noise",
                 "radial, ring width from the frame's stated noise (variant)", rings="noise")
register_variant(RadialMatcher, "radial_paper",
                 "radial as the paper writes it: R and dr from the observed and the "
                 "navigation stars, l >= 3/4 Nq (variant)", **LITERAL)
register_variant(RadialMatcher, "radial_paper_patch",
                 "radial_paper within a known sky patch, as the paper ran it (variant)",
                 **LITERAL, patch_deg=PATCH_DEG)
register_variant(RadialMatcher, "radial_patch",
                 "radial within a known sky patch (variant)", patch_deg=PATCH_DEG)
register_variant(RadialMatcher, "sss", "side-side-side over every catalog star, no radial "
                 "prefilter (the improved triangle paper's baseline, variant)",
                 prefilter=False)
register_variant(RadialMatcher, "sss_patch", "side-side-side over a known sky patch's "
                 "catalog stars (the improved triangle paper's baseline, variant)",
                 prefilter=False, patch_deg=PATCH_DEG)
register_variant(RadialMatcher, "sss_paper", "side-side-side by the improved triangle "
                 "paper's equation 5 alone: no mirror check, fourth star or cap (variant)",
                 prefilter=False, literal=True)
register_variant(RadialMatcher, "sss_paper_patch", "sss_paper over a known sky patch's "
                 "catalog stars, as the paper ran its baseline (variant)",
                 prefilter=False, literal=True, patch_deg=PATCH_DEG)
