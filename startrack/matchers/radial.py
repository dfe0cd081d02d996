"""Radial features, then triangles (seed 002): a shortlist per star, then side-side-side.

Each of the brightest observed stars gets a radial feature from all the other observed
stars; the catalog stars whose features share at least ``frac`` of its rings form its
shortlist. The classic triangle test (three inter-star angles within the noise window)
then runs only over the shortlists: m1 * m2 * m3 candidate triangles instead of every
catalog triangle. A catalog star near a frame edge sees neighbours outside the frame and
an observed star near the edge misses some; the score counts only the rings the observed
star occupies, so extra catalog rings cost nothing.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import combinations

import numpy as np

from startrack.database import StarDatabase
from startrack.database.radial import RadialTable, observed_masks
from startrack.matchers.base import Matcher, MatcherConfig, register
from startrack.matching.geometry import angle_table, handedness, triple_products
from startrack.types import Hypothesis, MatchDiagnostics, Observation


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
                 min_rings: int = 4, max_matches: int = 8) -> None:
        super().__init__(database, config)
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
        self.frac, self.cap, self.min_rings, self.max_matches = frac, cap, min_rings, max_matches
        self._table: RadialTable | None = None

    def prepare(self) -> None:
        self._table = self.database.radial(self.radius_rad, self.ring_width_rad)

    @property
    def table(self) -> RadialTable:
        if self._table is None:
            self.prepare()
        return self._table

    def shortlists(self, obs: Observation, n: int) -> list[np.ndarray]:
        """Catalog candidates of each of the first ``n`` observed stars, best first."""
        table = self.table
        single, double, need = observed_masks(obs.vectors, np.arange(n), table.radius_rad,
                                              table.ring_width_rad, self.angle_tolerance(obs))
        lists = []
        for k in range(n):
            if need[k] < self.min_rings:
                lists.append(np.zeros(0, np.int64))
                continue
            rows, _ = table.shortlist(single[k], double[k], int(need[k]), self.frac, self.cap)
            lists.append(rows.astype(np.int64))
        return lists

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics) -> Iterator[Hypothesis]:
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
            ab = np.abs(angle_table(cat[a], cat[b]) - obs_d[a, b]) <= eps
            if not ab.any():
                continue
            bc = np.abs(angle_table(cat[b], cat[c]) - obs_d[b, c]) <= eps
            ac = np.abs(angle_table(cat[a], cat[c]) - obs_d[a, c]) <= eps
            ia, ib, ic = np.nonzero(ab[:, :, None] & bc[None, :, :] & ac[:, None, :])
            if len(ia) == 0:
                continue
            ra, rb, rc = lists[a][ia], lists[b][ib], lists[c][ic]
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
