"""The tracking bench: frame sequences along a trajectory, solved frame after frame.

A sequence starts at a random attitude (from the seed) and turns at a constant body rate
along :data:`RATE_AXIS` (the issue's (1, 0.5, 2) deg/s direction), ``rate_dps`` being the
magnitude; optional events blank a run of frames (a lens cap: no stars) and turn the
attitude by ``jump_deg`` from a frame on. Each frame's centroids are the true positions
plus noise, with dropouts and false stars, as the Monte Carlo bench makes them.

Methods, run on the same frames one after the other within each frame (so a load on the
machine hits all alike): ``<m>+track`` (our :class:`~startrack.tracking._lock_state.Tracker`
falling
back to matcher ``<m>``), ``<m>`` (lost-in-space alone, the reference for the time ratio),
and ``tetra3rs+hint`` (tetra3rs's own tracking: its last solution as ``attitude_hint``
with ``strict_hint=True``, then its lost-in-space when that fails), when installed.

Lock: a frame *loses lock* when the frame before was solved and it is not solved by
tracking; the frames to reacquire count from that frame to the next solved one (0: lost-
in-space solved the same frame).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from startrack.attitude import random_attitudes
from startrack.bench._metrics import score_frame, summarise
from startrack.camera import Camera
from startrack.match_records import MatchDiagnostics, Observation, Solution
from startrack.simulate import constant_rate, observe
from startrack.sky import Catalog
from startrack.solver import Identifier
from startrack.tracking import Tracker

RATE_AXIS = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])
VARIABLES = ("rate_dps", "noise_px", "false_stars", "missing")
PEER = "tetra3rs+hint"
PEER_LIS = "tetra3rs"  # its lost-in-space alone on every frame: what its hint saves


@dataclass(frozen=True)
class TrackCondition:
    """One sequence setting: rate magnitude (deg/s along RATE_AXIS), centroid noise (px),
    false stars per frame, star dropout probability."""

    rate_dps: float = float(np.linalg.norm([1.0, 0.5, 2.0]))
    noise_px: float = 0.5
    false_stars: int = 2
    missing: float = 0.1

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class SeqFrame:
    obs: Observation
    truth_rows: np.ndarray  # catalog row of each observed star, -1 for a false star
    rotation: Rotation
    n_in_view: int


def oat_conditions(levels: dict[str, tuple]) -> list[TrackCondition]:
    """The base condition (first value of each variable), then one variable at a time."""
    base = {v: levels[v][0] for v in VARIABLES}
    out = [TrackCondition(**base)]
    for var in VARIABLES:
        out += [TrackCondition(**{**base, var: value}) for value in levels[var][1:]]
    return out


def sequence_rotations(r0: Rotation, rate_vector, fps: float, count: int,
                       jump_at: int | None = None, jump_deg: float = 10.0) -> Rotation:
    """The trajectory's attitudes; from frame ``jump_at`` on, turned by ``jump_deg``
    about the camera x axis (a sudden jump the tracker cannot predict)."""
    rotations = constant_rate(r0, rate_vector, fps, count).rotations
    if jump_at is None or jump_at >= count:
        return rotations
    jump = Rotation.from_rotvec([math.radians(jump_deg), 0.0, 0.0])
    return Rotation.concatenate([rotations[:jump_at], rotations[jump_at:] * jump])


def seeded_rotations(cond: TrackCondition, count: int, fps: float, seed: int,
                     jump_at: int | None = None, jump_deg: float = 10.0) -> Rotation:
    """The attitudes of the sequence ``seed`` names: a random start (from the seed) turning
    at ``cond.rate_dps`` along :data:`RATE_AXIS` (:func:`sequence_rotations`)."""
    r0 = random_attitudes(1, np.random.default_rng([seed, 0]))[0]
    return sequence_rotations(r0, RATE_AXIS * cond.rate_dps, fps, count, jump_at, jump_deg)


def make_sequence(catalog: Catalog, camera: Camera, cond: TrackCondition, count: int,
                  fps: float, seed: int, *, blank: tuple[int, int] | None = None,
                  jump_at: int | None = None, jump_deg: float = 10.0) -> list[SeqFrame]:
    """``count`` frames of one sequence; frames ``blank[0] <= k < blank[1]`` have no stars."""
    rotations = seeded_rotations(cond, count, fps, seed, jump_at, jump_deg)
    sigma = max(cond.noise_px, 0.05)
    frames = []
    for k in range(count):  # one scene per frame; each is vectorised over its stars
        rot = rotations[k]
        rng = np.random.default_rng([seed, k, 1])
        sc = observe(catalog, camera, rot, rng, missing=cond.missing,
                     false_stars=int(cond.false_stars))
        n_in_view = sc.n_real
        if blank is not None and blank[0] <= k < blank[1]:
            sc = observe(catalog, camera, rot, rng, missing=1.0)  # nothing reaches the sensor
        x = sc.x + rng.normal(0.0, cond.noise_px, len(sc)) if cond.noise_px else sc.x
        y = sc.y + rng.normal(0.0, cond.noise_px, len(sc)) if cond.noise_px else sc.y
        order = np.argsort(sc.mag, kind="stable")
        obs = Observation.from_pixels(x[order], y[order], camera, sigma)
        frames.append(SeqFrame(obs, sc.catalog_row[order], rot, n_in_view))
    return frames


Runner = Callable[[Observation], Solution]


def ours(identifier: Identifier) -> Runner:
    """Our tracker over ``identifier``'s database, falling back to its matcher."""
    tracker = Tracker()
    name = identifier.matcher.name

    def run(obs: Observation) -> Solution:
        return tracker.step(obs, identifier.database, identifier.verify_config,
                            identifier.identify, name)
    return run


def lost_in_space(identifier: Identifier) -> Runner:
    """Lost-in-space on every frame, with no state."""
    return identifier.identify


def tetra3rs_hinted(identifier: Identifier, hinted: bool = True) -> Runner:
    """tetra3rs with its last solution as ``attitude_hint`` (strict), then its lost-in-
    space; its own answer (and its own acceptance test) is taken as it is. With
    ``hinted`` False, its lost-in-space alone on every frame (``PEER_LIS``)."""
    from startrack.matchers import attitude_from_tetra3rs, get_matcher, tetra3rs_centroids

    peer = get_matcher("tetra3rs")(identifier.database)
    peer.prepare()
    catalog = identifier.database.catalog
    state: dict = {"hint": None}
    name = PEER if hinted else PEER_LIS

    def run(obs: Observation) -> Solution:
        kwargs = {"camera_model": peer._camera_for(obs), **peer.solve_kwargs}
        cents = tetra3rs_centroids(obs)
        t0 = time.perf_counter()
        result, mode = None, "tracking"
        if hinted and state["hint"] is not None and len(obs) >= 3:
            result = peer._solver.solve_from_centroids(cents, attitude_hint=state["hint"],
                                                       strict_hint=True, **kwargs)
        if not result and len(obs) >= 3:
            result, mode = peer._solver.solve_from_centroids(cents, **kwargs), "lost_in_space"
        ms = (time.perf_counter() - t0) * 1000.0
        diag = MatchDiagnostics(method_ms=ms)
        if not result or result.parity_flip:
            return Solution(False, name, diagnostics=diag, identify_ms=ms, reason="no_match")
        state["hint"] = np.asarray(result.quaternion, dtype=np.float64)
        cat = catalog.index_of(np.asarray(result.matched_catalog_ids, dtype=np.int64))
        obs_index = np.asarray(result.matched_centroids, dtype=np.int64)
        return Solution(True, name, attitude_from_tetra3rs(result.rotation_matrix_icrs_to_camera),
                        obs_index=obs_index[cat >= 0], cat_index=cat[cat >= 0],
                        diagnostics=diag, identify_ms=ms, mode=mode)
    return run


def run_sequence(frames: list[SeqFrame], runners: dict[str, Callable[[], Runner]],
                 threshold_arcsec: float = 60.0, interleaved: bool = True) -> pd.DataFrame:
    """Every method on every frame of one sequence (fresh state each), one row each:
    each frame by every method in turn (``interleaved``: each solve starts with the
    caches the other methods left), else the whole sequence by one method before the
    next (as a tracker in flight runs, nothing else between its frames)."""
    started = {name: make() for name, make in runners.items()}
    order = ([(k, name) for k in range(len(frames)) for name in started] if interleaved
             else [(k, name) for name in started for k in range(len(frames))])
    rows = []
    for k, name in order:
        frame = frames[k]
        solution = started[name](frame.obs)
        score = score_frame(solution, frame.truth_rows, frame.rotation, frame.n_in_view,
                            threshold_arcsec=threshold_arcsec,
                            sigma_arcsec=math.degrees(frame.obs.sigma_rad) * 3600.0)
        rows.append({"method": name, "frame": k, "n_centroids": len(frame.obs),
                     "mode": solution.mode if solution.solved else "",
                     "lock": solution.lock or "", **score.to_dict()})
    return pd.DataFrame(rows)


def lock_events(solved: np.ndarray, tracked: np.ndarray) -> tuple[int, list[int]]:
    """Losses of lock and, per loss, the frames to reacquire (see the module doc)."""
    solved, tracked = np.asarray(solved, bool), np.asarray(tracked, bool)
    losses = np.flatnonzero(solved[:-1] & ~tracked[1:]) + 1
    waits = []
    for k in losses:
        later = np.flatnonzero(solved[k:])
        if len(later):
            waits.append(int(later[0]))
    return len(losses), waits


def summarise_tracking(frames: pd.DataFrame, key_columns: list[str]) -> pd.DataFrame:
    """metrics.summarise's columns plus tracked rate, losses of lock and frames to
    reacquire, per (condition, method)."""
    base = summarise(frames, key_columns)
    extra = []
    for _, g in frames.groupby(key_columns, sort=False):
        g = g.sort_values("frame")
        tracked = (g["mode"] == "tracking").to_numpy()
        solved = g["solved"].to_numpy(bool)
        # A stateless method holds no lock: it "loses" one only when it stops solving.
        held = tracked if is_tracking_method(str(g["method"].iloc[0])) else solved
        losses, waits = lock_events(solved, held)
        extra.append({"tracked_rate": float(tracked.mean()), "losses": losses,
                      "reacquire_frames_mean": float(np.mean(waits)) if waits else float("nan"),
                      "reacquire_frames_max": max(waits) if waits else float("nan")})
    return pd.concat([base, pd.DataFrame(extra)], axis=1)


def is_tracking_method(name: str) -> bool:
    return name.endswith("+track") or name == PEER


def peer_available() -> bool:
    """Whether tetra3rs (with ``attitude_hint``) is importable here."""
    try:
        import tetra3rs  # noqa: F401
    except ImportError:
        return False
    return True


def runners_for(identifiers: dict[str, Identifier], with_peer: bool) -> dict:
    """The bench's methods: each matcher tracked and alone, and tetra3rs when asked."""
    runners: dict[str, Callable[[], Runner]] = {}
    for name, ident in identifiers.items():
        runners[f"{name}+track"] = lambda ident=ident: ours(ident)
        runners[name] = lambda ident=ident: lost_in_space(ident)
    if with_peer and identifiers:
        first = next(iter(identifiers.values()))
        runners[PEER] = lambda: tetra3rs_hinted(first)
        runners[PEER_LIS] = lambda: tetra3rs_hinted(first, hinted=False)
    return runners


def run_tracking_bench(catalog: Catalog, camera: Camera, conditions: list[TrackCondition],
                       methods: tuple[str, ...], frames: int, fps: float, seed: int,
                       with_peer: bool, threshold_arcsec: float = 60.0,
                       progress: Callable[[str], None] | None = None
                       ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every condition's sequence through every method: (per frame, per condition)."""
    identifiers = {m: Identifier(camera, catalog, m) for m in methods}
    parts = []
    for c, cond in enumerate(conditions):
        if progress:
            progress(f"condition {c + 1}/{len(conditions)}: {cond.to_dict()}")
        seq = make_sequence(catalog, camera, cond, frames, fps, seed + c)
        df = run_sequence(seq, runners_for(identifiers, with_peer), threshold_arcsec)
        parts.append(df.assign(condition=c, **cond.to_dict()))
    per_frame = pd.concat(parts, ignore_index=True)
    keys = ["condition", *VARIABLES, "method"]
    return per_frame, summarise_tracking(per_frame, keys)

__all__ = [
    "PEER", "PEER_LIS", "RATE_AXIS", "Runner", "SeqFrame", "TrackCondition", "VARIABLES",
    "is_tracking_method", "lock_events", "lost_in_space", "make_sequence", "oat_conditions",
    "ours", "peer_available", "run_sequence", "run_tracking_bench", "runners_for",
    "seeded_rotations", "sequence_rotations", "summarise_tracking", "tetra3rs_hinted",
]
