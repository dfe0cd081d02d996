"""Every observed star identified, as the improved triangle paper's experiment counts them:
each star labelled by the catalog triangles that its observed triangles match.

The paper identifies star by star (its Tables 3 and 4), not one attitude per frame, so two
observed stars can be given the same catalog star: the plain triangle method's typical
error (its Table 4). The rule here, the same for the radial-feature matcher and its plain
side-side-side baseline (the paper does not spell one out): every star forms triangles
with pairs of its ``neighbours`` nearest observed stars; a triangle that matches exactly
one catalog triangle (equation 5, all three sides within the angle tolerance) votes for
the identity of each of its three stars; an ambiguous triangle votes for nothing; a star
takes the catalog star with the most votes, none on a tie.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from startrack.match_records import Observation
from startrack.matchers import angle_table


@dataclass(frozen=True)
class StarLabels:
    """Per observed star: ``cat_row`` its catalog row (-1: not identified) and ``votes``
    the unambiguous triangles behind that label."""

    cat_row: np.ndarray
    votes: np.ndarray


def star_triangles(obs_d: np.ndarray, neighbours: int) -> list[tuple[int, int, int]]:
    """Every star with every pair of its ``neighbours`` nearest stars, each triangle once
    (sorted indices), in a fixed order."""
    n = len(obs_d)
    out: set[tuple[int, int, int]] = set()
    for k in range(n):
        near = [int(j) for j in np.argsort(obs_d[k], kind="stable") if j != k][:neighbours]
        for a, b in combinations(near, 2):
            out.add(tuple(sorted((k, a, b))))
    return sorted(out)


def label_every_star(matcher, obs: Observation, neighbours: int = 4) -> StarLabels:
    """Label every star of ``obs`` with ``matcher`` (a radial matcher or variant: its
    shortlists, or every catalog star of its patch or sky when it has no prefilter)."""
    n = len(obs)
    if n < 3:
        return StarLabels(np.full(n, -1, np.int64), np.zeros(n, np.int64))
    lists = matcher.shortlists(obs, n)
    eps = matcher.angle_tolerance(obs)
    obs_d = angle_table(obs.vectors, obs.vectors)
    cat = [matcher.database.vectors[s] for s in lists]
    votes = [Counter() for _ in range(n)]
    for tri in star_triangles(obs_d, neighbours):
        if any(len(lists[s]) == 0 for s in tri):
            continue
        found = matcher.triangle_matches(lists, cat, obs_d, tri, eps)
        if found is None:
            continue
        rows = np.column_stack(found[1])
        rows = rows[(rows[:, 0] != rows[:, 1]) & (rows[:, 1] != rows[:, 2])
                    & (rows[:, 0] != rows[:, 2])]
        if len(rows) != 1:
            continue
        for star, row in zip(tri, rows[0], strict=True):
            votes[star][int(row)] += 1
    cat_row = np.full(n, -1, np.int64)
    count = np.zeros(n, np.int64)
    for k, tally in enumerate(votes):
        top = tally.most_common(2)
        if top and (len(top) == 1 or top[0][1] > top[1][1]):
            cat_row[k], count[k] = top[0]
    return StarLabels(cat_row, count)


def score_labels(labels: StarLabels, truth_rows: np.ndarray) -> dict[str, int]:
    """Counts of one image: stars ``identified``, ``right``, ``misidentified`` (a wrong
    catalog star, or any for a false star), of those ``false_labelled``, and
    ``duplicates`` (catalog stars given to two or more observed stars)."""
    truth = np.asarray(truth_rows, dtype=np.int64)
    given = labels.cat_row >= 0
    right = given & (labels.cat_row == truth)
    _, counts = np.unique(labels.cat_row[given], return_counts=True)
    return {"stars": len(truth), "real": int(np.count_nonzero(truth >= 0)),
            "identified": int(given.sum()), "right": int(right.sum()),
            "misidentified": int((given & ~right).sum()),
            "false_labelled": int((given & (truth < 0)).sum()),
            "duplicates": int(np.count_nonzero(counts > 1))}

__all__ = [
    "StarLabels", "label_every_star", "score_labels", "star_triangles",
]
