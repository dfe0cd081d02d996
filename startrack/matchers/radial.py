"""Radial features, then triangles (seed 002): a shortlist per star, then side-side-side.

Each of the brightest observed stars gets a radial feature from all the other observed
stars; the catalog stars whose features share at least ``frac`` of its rings form its
shortlist. The classic triangle test (three inter-star angles within the noise window)
then runs only over the shortlists: m1 * m2 * m3 candidate triangles instead of every
catalog triangle. A catalog star near a frame edge sees neighbours outside the frame and
an observed star near the edge misses some; the score counts only the rings the observed
star occupies, so extra catalog rings cost nothing.

Variants (constructor keywords; registered names in brackets): ``rings="noise"`` sets the
ring width from each frame's stated noise instead of ``noise_px`` [radial_noise];
``rings="paper"`` takes R and dr per frame as the paper does, the largest and smallest
separation among the field's stars [radial_paper]; ``patch_deg`` restricts the catalog to
a known sky patch around ``patch_center`` (set per frame by the caller) [radial_patch,
with the paper's rings]; ``prefilter=False`` drops the radial shortlist, so the
side-side-side test runs over every catalog star through the pair table: the paper's
baseline [sss].
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import combinations

import numpy as np

from startrack.database import StarDatabase
from startrack.database.radial import (
    RadialTable,
    build_radial_arrays,
    observed_masks,
    radial_table_from_arrays,
)
from startrack.matchers.base import Matcher, MatcherConfig, register, register_variant
from startrack.matching.geometry import angle_table, handedness, triple_products
from startrack.types import Hypothesis, MatchDiagnostics, Observation

RINGS = ("fixed", "noise", "paper")


def field_rings(vectors: np.ndarray) -> tuple[float, float]:
    """The paper's rings for one frame: R the largest, dr the smallest separation among
    the field's stars (radians)."""
    d = angle_table(vectors, vectors)[np.triu_indices(len(vectors), 1)]
    return float(d.max()), float(max(d.min(), 1e-9))


def pair_triangles(pairs, obs_d: np.ndarray, a: int, b: int, c: int,
                   eps: float) -> np.ndarray:
    """Catalog triangles (K x 3 rows, in a, b, c order) whose three sides match the
    observed ones within ``eps``: side-side-side over every catalog star (pair table)."""
    def both(p: int, q: int) -> tuple[np.ndarray, np.ndarray]:
        i, j, _ = pairs.query(obs_d[p, q] - eps, obs_d[p, q] + eps)
        i, j = i.astype(np.int64), j.astype(np.int64)
        return np.concatenate([i, j]), np.concatenate([j, i])

    ab_i, ab_j = both(a, b)
    bc_i, bc_j = both(b, c)
    order = np.argsort(bc_i, kind="stable")
    lo = np.searchsorted(bc_i[order], ab_j, side="left")
    count = np.searchsorted(bc_i[order], ab_j, side="right") - lo
    rows = np.repeat(np.arange(len(ab_i)), count)
    pos = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
    tri = np.column_stack([ab_i[rows], ab_j[rows], bc_j[order[pos]]])
    tri = tri[tri[:, 0] != tri[:, 2]]
    ac_i, ac_j = both(a, c)
    base = int(max(tri.max(initial=0), ac_j.max(initial=0))) + 1
    return tri[np.isin(tri[:, 0] * base + tri[:, 2], ac_i * base + ac_j)]


@register
class RadialMatcher(Matcher):
    """Parameters: ``radius_deg`` (R; default: the radius holding ``target_neighbours``
    catalog stars on average, at most the image diagonal), ``ring_width_deg`` (dr;
    default: ``ring_sigma`` angle-noise sigmas at ``noise_px`` centroid noise, so that a
    noise window spans at most two rings), ``frac`` (share of the observed rings a catalog
    star must have), ``cap`` (longest shortlist), ``min_rings`` (an observed star with
    fewer rings is not distinctive enough for a shortlist), ``max_matches`` (catalog
    triangles tried per observed triangle)."""

    name = "radial"
    description = "radial-feature shortlists, then side-side-side triangles (seed 002)"

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 radius_deg: float | None = None, ring_width_deg: float | None = None,
                 target_neighbours: float = 20.0, noise_px: float = 0.3,
                 ring_sigma: float | None = None, frac: float = 0.75, cap: int = 10,
                 min_rings: int = 4, max_matches: int = 8, rings: str = "fixed",
                 prefilter: bool = True, patch_deg: float | None = None) -> None:
        super().__init__(database, config)
        if rings not in RINGS:
            raise ValueError(f"rings must be one of {', '.join(RINGS)}, got {rings!r}")
        self.rings, self.prefilter = rings, bool(prefilter)
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
        radius, width = field_rings(obs.vectors)
        key = (min(radius, self.database.max_angle_rad), width)
        if self._last[0] != key:  # the bench asks again for the same frame: keep one
            arrays = build_radial_arrays(self.database.pairs, len(self.database.vectors),
                                         *key)
            self._last = (key, radial_table_from_arrays(arrays, *key))
        return self._last[1]

    def in_patch(self) -> np.ndarray | None:
        """Catalog rows inside the known sky patch (None: lost in space)."""
        if self.patch_rad is None or self.patch_center is None:
            return None
        cos = self.database.vectors @ np.asarray(self.patch_center, dtype=np.float64)
        return np.flatnonzero(cos >= math.cos(self.patch_rad))

    def shortlists(self, obs: Observation, n: int) -> list[np.ndarray]:
        """Catalog candidates of each of the first ``n`` observed stars, best first."""
        if not self.prefilter:
            rows = self.in_patch()
            every = np.arange(len(self.database.vectors)) if rows is None else rows
            return [every] * n
        table, patch = self.frame_table(obs), self.in_patch()
        single, double, need = observed_masks(obs.vectors, np.arange(n), table.radius_rad,
                                              table.ring_width_rad, self.angle_tolerance(obs))
        cap = self.cap if patch is None else len(self.database.vectors)
        lists = []
        for k in range(n):
            if need[k] < self.min_rings:
                lists.append(np.zeros(0, np.int64))
                continue
            rows, _ = table.shortlist(single[k], double[k], int(need[k]), self.frac, cap)
            if patch is not None:
                rows = rows[np.isin(rows, patch)][: self.cap]
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
            found = self._sss(lists, cat, obs_d, (a, b, c), eps)
            if found is None:
                continue
            (ia, ib, ic), (ra, rb, rc) = found
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

    def _sss(self, lists, cat, obs_d, stars, eps):
        """Side-side-side over the shortlists (or every catalog star): positions in the
        lists and catalog rows of the matching triangles, None when there is none."""
        a, b, c = stars
        if not self.prefilter:
            tri = pair_triangles(self.database.pairs, obs_d, a, b, c, eps)
            patch = self.in_patch()
            if patch is not None:
                tri = tri[np.isin(tri, patch).all(axis=1)]
            if len(tri) == 0:
                return None
            pos = (np.searchsorted(lists[a], tri[:, 0]), np.searchsorted(lists[b], tri[:, 1]),
                   np.searchsorted(lists[c], tri[:, 2]))
            return pos, (tri[:, 0], tri[:, 1], tri[:, 2])
        ab = np.abs(angle_table(cat[a], cat[b]) - obs_d[a, b]) <= eps
        if not ab.any():
            return None
        bc = np.abs(angle_table(cat[b], cat[c]) - obs_d[b, c]) <= eps
        ac = np.abs(angle_table(cat[a], cat[c]) - obs_d[a, c]) <= eps
        ia, ib, ic = np.nonzero(ab[:, :, None] & bc[None, :, :] & ac[:, None, :])
        if len(ia) == 0:
            return None
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


register_variant(RadialMatcher, "radial_noise",
                 "radial, ring width from the frame's stated noise (variant)", rings="noise")
register_variant(RadialMatcher, "radial_paper",
                 "radial, the paper's R and dr per frame (variant)", rings="paper")
register_variant(RadialMatcher, "radial_patch",
                 "radial, paper rings within a known sky patch (variant)", rings="paper",
                 patch_deg=4.0)
register_variant(RadialMatcher, "sss", "side-side-side over every catalog star, no radial "
                 "prefilter (seed 002's baseline, variant)", prefilter=False)
