"""Raw matcher scoring: a matcher's own hypotheses judged against the truth, unverified.

The bench scores verified solutions, and the shared verification refuses most wrong
hypotheses whatever the method. The seed papers had no such stage: a matcher's first
answer *was* its identification. This module measures that: the first hypothesis a
matcher yields (is every star in it right? how many identities are wrong?), and how many
wrong hypotheses come before the first right one (the work verification has to refuse).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from startrack.bench._runner import RunSpec, bench_frame, load_bench, point_patch
from startrack.match_records import MatchDiagnostics, Observation
from startrack.matchers import Matcher

DEFAULT_LIMIT = 20


@dataclass(frozen=True)
class RawScore:
    """One matcher on one frame, without verification.

    ``first_*`` describe the first hypothesis (all zero / False when there is none);
    ``first_wrong_ids`` counts its observed stars given the wrong catalog star, false
    stars included; ``first_false_used`` those that are false stars; ``first_duplicate``:
    two observed stars given the same catalog star (the triangle error the radial-feature
    triangle paper reports).
    ``rank_right``: 1-based position of the first all-right hypothesis among the first
    ``limit`` distinct ones (0: none); ``wrong_before``: wrong hypotheses ahead of it (all
    looked at when none is right). ``first_pairs_off``: star pairs of the first hypothesis
    whose observed angle misses the catalog angle by more than the matcher's angle
    tolerance (a pair the matcher never checked, or checked with another tolerance).
    """

    yielded: bool
    first_right: bool
    first_stars: int
    first_wrong_ids: int
    first_false_used: int
    first_duplicate: bool
    first_ms: float
    rank_right: int
    wrong_before: int
    looked_at: int
    first_pairs_off: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


def score_hypotheses(matcher: Matcher, obs: Observation, truth_rows: np.ndarray,
                     limit: int = DEFAULT_LIMIT) -> RawScore:
    """Pull up to ``limit`` distinct hypotheses from ``matcher`` for ``obs`` and score them
    against ``truth_rows`` (catalog row of each observed star, -1 for a false star)."""
    truth_rows = np.asarray(truth_rows, dtype=np.int64)
    diag = MatchDiagnostics()
    seen: set[tuple] = set()
    first = None
    first_ms = 0.0
    rank = wrong = looked = 0
    t0 = time.perf_counter()
    iterator = matcher.hypotheses(obs, diag) if len(obs) >= 3 else iter(())
    for hyp in iterator:
        obs_i = np.asarray(hyp.obs_index, dtype=np.int64)
        cat_i = np.asarray(hyp.cat_index, dtype=np.int64)
        if first is None:
            first_ms = (time.perf_counter() - t0) * 1000.0
            first = (obs_i, cat_i)
        key = tuple(sorted(zip(obs_i.tolist(), cat_i.tolist(), strict=True)))
        if key in seen:
            continue
        seen.add(key)
        looked += 1
        if np.all(truth_rows[obs_i] == cat_i):
            rank = looked
            break
        wrong += 1
        if looked >= limit:
            break
    if first is None:
        return RawScore(False, False, 0, 0, 0, False, 0.0, 0, 0, 0)
    obs_i, cat_i = first
    off = pairs_off(obs.vectors[obs_i], matcher.database.vectors[cat_i],
                    matcher.angle_tolerance(obs))
    right = truth_rows[obs_i] == cat_i
    return RawScore(
        yielded=True,
        first_right=bool(right.all()),
        first_stars=len(obs_i),
        first_wrong_ids=int((~right).sum()),
        first_false_used=int((truth_rows[obs_i] < 0).sum()),
        first_duplicate=len(np.unique(cat_i)) < len(cat_i),
        first_ms=first_ms,
        rank_right=rank,
        wrong_before=wrong,
        looked_at=looked,
        first_pairs_off=off,
    )


def pairs_off(observed: np.ndarray, catalog: np.ndarray, tol: float) -> int:
    """Pairs (of all k(k-1)/2) whose observed and catalog angles differ by more than
    ``tol`` radians: the pairs a hypothesis gets wrong whatever its other pairs say."""
    def angles(v: np.ndarray) -> np.ndarray:
        i, j = np.triu_indices(len(v), 1)
        return np.arccos(np.clip(np.einsum("ij,ij->i", v[i], v[j]), -1.0, 1.0))

    return int(np.count_nonzero(np.abs(angles(observed) - angles(catalog)) > tol))


class TimedMatcher:
    """A matcher seen through a stopwatch: ``ms`` is the time spent inside its
    hypotheses() generator (matching, with the first-test screening a matcher may do
    there: the angle matcher's), the rest of identify() is verification."""

    def __init__(self, matcher: Matcher) -> None:
        self._matcher = matcher
        self.ms = 0.0

    def __getattr__(self, name: str):
        return getattr(self._matcher, name)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None):
        it = self._matcher.hypotheses(obs, diag, screen_rad)
        while True:
            t0 = time.perf_counter()
            try:
                hyp = next(it)
            except StopIteration:
                self.ms += (time.perf_counter() - t0) * 1000.0
                return
            self.ms += (time.perf_counter() - t0) * 1000.0
            yield hyp


def _top_ids_right(sol, truth_rows: np.ndarray, n: int = 5) -> bool:
    """A solution scored on the ``n`` brightest spots only: at least 3 of them identified,
    every identity among them right."""
    if not sol.solved:
        return False
    keep = np.asarray(sol.obs_index) < n
    rows = np.asarray(sol.cat_index)[keep]
    return bool(keep.sum() >= 3 and np.all(truth_rows[np.asarray(sol.obs_index)[keep]] == rows))


def timed_runs(ident, obs: Observation, repeats: int, truth_rows: np.ndarray) -> dict:
    """The fastest of ``repeats`` verified identify() runs, split into matcher time and the
    rest (verification, attitude), with the first run's diagnostics."""
    from startrack.solver import identify

    best = None
    for _ in range(repeats):
        timed = TimedMatcher(ident.matcher)
        sol = identify(obs, timed, ident.verify_config)
        if best is None or sol.identify_ms < best[0].identify_ms:
            best = (sol, timed.ms, best[2] if best else sol.diagnostics)
    sol, matcher_ms, diag = best
    row = dict(seq_ms=sol.identify_ms, matcher_ms=matcher_ms,
               verify_ms=sol.identify_ms - matcher_ms, solved=sol.solved,
               top5_ids_right=_top_ids_right(sol, np.asarray(truth_rows)),
               candidates=diag.candidates, pivots=diag.pivots, hypotheses=diag.hypotheses)
    for k, v in diag.extra.items():
        if isinstance(v, (int, float)):
            row[f"x_{k}"] = v
        elif isinstance(v, list) and v:
            row[f"x_{k}_mean"] = float(np.mean(v))
    return row


def top_correct(ident, bf, n: int = 5) -> bool:
    """Verified and right when the identifier sees only the ``n`` brightest spots (the
    papers' budget): verification then has no other star to confirm with."""
    obs = bf.obs
    k = min(n, len(obs))
    top = Observation(obs.vectors[:k], obs.x[:k], obs.y[:k], obs.camera, obs.sigma_rad)
    sol = ident.identify(top)
    if not sol.solved:
        return False
    return bool(np.all(np.asarray(bf.truth_rows)[sol.obs_index] == sol.cat_index))


def raw_unit(spec: RunSpec, condition_index: int, frame: int, *, limit: int = DEFAULT_LIMIT,
             repeats: int = 0) -> list[dict]:
    """Frame ``frame`` of condition ``condition_index`` (the bench's own frame, see
    frames.py) through every method of ``spec``: a row per method with its RawScore and,
    when ``repeats`` > 0, the fastest of ``repeats`` verified identify() runs in this
    process (``seq_ms``, a timing less exposed to a loaded machine than one run; of it
    ``matcher_ms`` inside the matcher, ``verify_ms`` the rest) with the first run's
    diagnostics, the matcher's extra counters as ``x_<name>`` (numbers only), and
    ``top5_correct`` (:func:`top_correct`); ``top5_ids_right``: the full solution scored on
    the five brightest spots only."""
    bench, condition, bf = bench_frame(spec, condition_index, frame)
    n_top = min(spec.max_stars, len(bf.truth_rows))
    rows = []
    for name in spec.methods:
        ident = bench.identifier(name, bf.obs.camera)
        point_patch(ident.matcher, bf)
        row = {"condition": condition_index, **condition.to_dict(), "frame": frame,
               "method": name, "real_in_top": int(np.count_nonzero(bf.truth_rows[:n_top] >= 0)),
               **score_hypotheses(ident.matcher, bf.obs, bf.truth_rows, limit).to_dict()}
        if repeats > 0:
            row.update(timed_runs(ident, bf.obs, repeats, bf.truth_rows))
            row["top5_correct"] = top_correct(ident, bf)
        rows.append(row)
    return rows


def _chunk(unit_fn, spec: RunSpec, units: list[tuple[int, int]], kwargs: dict) -> list[dict]:
    return [row for c, f in units for row in unit_fn(spec, c, f, **kwargs)]


def map_units(unit_fn, spec: RunSpec, frames: int, *, jobs: int = 1,
              **kwargs) -> pd.DataFrame:
    """``unit_fn(spec, condition, frame, **kwargs)`` (a module-level function returning row
    dicts) over the first ``frames`` frames of every condition, in canonical order, on
    ``jobs`` local processes; the rows as one table."""
    units = [(c, f) for c in range(len(spec.conditions))
             for f in range(min(frames, spec.frames))]
    if jobs <= 1:
        return pd.DataFrame(_chunk(unit_fn, spec, units, kwargs))
    from concurrent.futures import ProcessPoolExecutor

    size = max(1, len(units) // (8 * jobs))
    chunks = [units[i:i + size] for i in range(0, len(units), size)]
    with ProcessPoolExecutor(max_workers=jobs, initializer=load_bench,
                             initargs=(spec,)) as pool:
        parts = pool.map(_chunk, [unit_fn] * len(chunks), [spec] * len(chunks), chunks,
                         [kwargs] * len(chunks))
        return pd.DataFrame([row for part in parts for row in part])


def raw_pass(spec: RunSpec, frames: int, *, limit: int = DEFAULT_LIMIT, repeats: int = 0,
             jobs: int = 1) -> pd.DataFrame:
    """:func:`raw_unit` over the first ``frames`` frames of every condition, in canonical
    order, on ``jobs`` local processes (keep 1 when ``seq_ms`` timings matter)."""
    return map_units(raw_unit, spec, frames, jobs=jobs, limit=limit, repeats=repeats)


def summarise_raw(rows: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """Per group of ``keys``: rates of the first hypothesis being absent, right or wrong,
    wrong identities per frame, and the wrong hypotheses verification had to refuse."""
    out = []
    for key, g in rows.groupby(keys, sort=False):
        yielded = g["yielded"].astype(bool)
        right = g["first_right"].astype(bool)
        out.append({
            **dict(zip(keys, key if isinstance(key, tuple) else (key,), strict=True)),
            "frames": len(g),
            "none_rate": float((~yielded).mean()),
            "first_right_rate": float(right.mean()),
            "first_wrong_rate": float((yielded & ~right).mean()),
            "first_wrong_frames": int((yielded & ~right).sum()),
            "wrong_ids": int(g["first_wrong_ids"].sum()),
            "wrong_ids_per_frame": float(g["first_wrong_ids"].mean()),
            "false_star_ids": int(g["first_false_used"].sum()),
            "duplicates": int(g["first_duplicate"].astype(bool).sum()),
            "right_within_limit": float((g["rank_right"] > 0).mean()),
            "wrong_before_mean": float(g["wrong_before"].mean()),
            "pairs_off_frames": int(((yielded & ~right) & (g["first_pairs_off"] > 0)).sum()),
            "first_ms_median": float(np.median(g.loc[yielded, "first_ms"]))
            if yielded.any() else float("nan"),
        })
    return pd.DataFrame(out)

__all__ = [
    "DEFAULT_LIMIT", "RawScore", "TimedMatcher", "pairs_off", "raw_pass", "raw_unit",
    "score_hypotheses", "summarise_raw", "timed_runs", "top_correct",
]
