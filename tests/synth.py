"""Synthetic observations for matcher tests (exact or noisy centroids of a known attitude,
false stars) and the small helpers the matcher tests share."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.database import StarDatabase
from startrack.match_records import MatchDiagnostics, Observation
from startrack.matchers import Matcher, MatcherConfig, get_matcher
from startrack.sky import Catalog
from startrack.solver import identify


@dataclass(frozen=True)
class SyntheticFrame:
    obs: Observation
    truth_rows: np.ndarray  # catalog row of each observed star, -1 for a false star
    rotation: Rotation


def synthetic_frame(catalog: Catalog, camera: Camera, rotation: Rotation,
                    rng: np.random.Generator, *, noise_px: float = 0.0, false_stars: int = 0,
                    missing: float = 0.0, sigma_px: float | None = None) -> SyntheticFrame:
    """Centroids of the catalog stars in view (brightest first), perturbed by Gaussian
    noise, with stars dropped and false stars inserted at random brightness ranks."""
    rows, x, y = stars_in_view(catalog, camera, rotation)
    keep = rng.random(len(rows)) >= missing
    rows, x, y = rows[keep], x[keep], y[keep]
    x = x + rng.normal(0.0, noise_px, len(x)) if noise_px > 0 else x
    y = y + rng.normal(0.0, noise_px, len(y)) if noise_px > 0 else y
    truth = rows.astype(np.int64)
    for _ in range(false_stars):
        pos = int(rng.integers(0, len(truth) + 1))
        x = np.insert(x, pos, rng.uniform(0, camera.width - 1))
        y = np.insert(y, pos, rng.uniform(0, camera.height - 1))
        truth = np.insert(truth, pos, -1)
    sigma = noise_px if sigma_px is None else sigma_px
    obs = Observation.from_pixels(x, y, camera, max(sigma, 0.05))
    return SyntheticFrame(obs, truth, rotation)


def frames(catalog: Catalog, camera: Camera, n: int, seed: int, *, min_stars: int = 8,
           **kw) -> Iterator[SyntheticFrame]:
    """Synthetic frames at ``n`` seeded random attitudes, skipping those with fewer than
    ``min_stars`` real stars in view; ``kw`` goes to :func:`synthetic_frame`."""
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(n, rng):
        frame = synthetic_frame(catalog, camera, rot, rng, **kw)
        if np.count_nonzero(frame.truth_rows >= 0) >= min_stars:
            yield frame


def with_false_star(frame: SyntheticFrame, position: int,
                    rng: np.random.Generator) -> tuple[Observation, np.ndarray]:
    """The frame's observation with one false star inserted at brightness rank
    ``position``, and the matching truth rows (-1 for the false star)."""
    obs = frame.obs
    x = np.insert(obs.x, position, rng.uniform(0, obs.camera.width - 1))
    y = np.insert(obs.y, position, rng.uniform(0, obs.camera.height - 1))
    return (Observation.from_pixels(x, y, obs.camera, obs.sigma_rad * obs.camera.f_px),
            np.insert(frame.truth_rows, position, -1))


def assert_correct(solution, truth_rows: np.ndarray) -> None:
    """The solution is solved and every star it identified is the true catalog row."""
    assert solution.solved
    assert np.all(truth_rows[solution.obs_index] == solution.cat_index)


def prepared_matcher(method: str, db: StarDatabase, config: MatcherConfig | None = None,
                     **params) -> Matcher:
    """The named matcher on ``db`` with its tables built (cached on ``db`` after the
    first call, so tests may call this freely)."""
    matcher = get_matcher(method)(db, config, **params)
    matcher.prepare()
    return matcher


def false_star_first(db: StarDatabase, seed: int = 32) -> tuple[Observation, np.ndarray]:
    """A noisy (0.3 px) frame of ``db``'s sky with a false star as its brightest star,
    and the truth rows: the matcher's first patterns all hold the false star."""
    frame = next(frames(db.catalog, db.camera, 3, seed=seed, noise_px=0.3))
    return with_false_star(frame, 0, np.random.default_rng(seed + 1000))


def false_stars_first(db: StarDatabase, count: int, seed: int = 32,
                      ) -> tuple[Observation, np.ndarray]:
    """A noisy (0.3 px) frame of ``db``'s sky with ``count`` false stars as its brightest,
    and the truth rows."""
    frame = next(frames(db.catalog, db.camera, 3, seed=seed, noise_px=0.3))
    rng = np.random.default_rng(seed + 1000)
    obs, truth = with_false_star(frame, 0, rng)
    for _ in range(count - 1):
        frame = SyntheticFrame(obs, truth, frame.rotation)
        obs, truth = with_false_star(frame, 0, rng)
    return obs, truth


def solved_past_false_star(method: str, db: StarDatabase, **params):
    """The named matcher's solution of :func:`false_star_first`'s frame, checked solved with
    every identified star right; returned for its diagnostics. ``params`` go to the
    matcher."""
    obs, truth = false_star_first(db)
    solution = identify(obs, prepared_matcher(method, db, **params))
    assert_correct(solution, truth)
    return solution


def first_hypothesis(matcher: Matcher, db: StarDatabase):
    """The matcher's first hypothesis on a noisy (0.3 px) frame of ``db``'s sky, checked to
    pair every star with its true catalog row, and the diagnostics counted up to it."""
    frame = next(frames(db.catalog, db.camera, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(matcher.hypotheses(frame.obs, diag)))
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
    return first, diag


def two_star_frame(db: StarDatabase) -> tuple[Observation, np.ndarray]:
    """Two stars of an exact frame of ``db``'s sky whose angle's window (as the angle
    matcher looks it up) holds exactly one catalog pair, and their catalog rows."""
    from startrack.matchers._shared.pair_joins import pair_index

    matcher = prepared_matcher("angle", db)
    index = pair_index(matcher._table(), len(db.vectors))
    for frame in frames(db.catalog, db.camera, 10, seed=3):
        obs = frame.obs
        for i in range(8):
            for j in range(i + 1, 8):
                two = Observation.from_pixels(obs.x[[i, j]], obs.y[[i, j]], obs.camera, 0.05)
                w = matcher._windows(index, two.vectors, matcher.angle_tolerance(two))[0, 1]
                if w[1] - w[0] == 1:
                    return two, frame.truth_rows[[i, j]]
    raise AssertionError("no two-star frame with a unique catalog pair")
