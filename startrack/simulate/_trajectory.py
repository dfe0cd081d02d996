"""Attitude sequences for simulated frame series: a constant body rate or a slew profile.

With a constant rate ``w`` (deg/s, camera frame) frame k of a series at ``fps`` frames
per second is at ``R0 * exp(w k / fps)``: the body rate turns camera-frame vectors, so
the increment multiplies on the right (``v_icrs = R0 exp(w t) v_cam``). A profile file
lists times and attitudes (CSV with columns ``t``, ``qw``, ``qx``, ``qy``, ``qz``:
seconds and the scalar-first camera-to-ICRS quaternion of docs/conventions.md); attitudes in
between are interpolated by SLERP. Each frame also carries its body rate, which the
renderer needs for motion blur.

A frame's time tag may be off (``[frames] time_tag_error_s``, the StarTrackerModel error
budget's timestamping term): frame k is rendered at its true time t_k but tagged
t_k + e_k, e_k ~ N(0, sigma) drawn from (seed, k) alone. A tracker that reports the attitude
it solves as the attitude at the tag is then off by the rotation over e_k: |w| |e_k| at a
constant rate w.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from startrack.errors import InputError

PROFILE_COLUMNS = ("t", "qw", "qx", "qy", "qz")


@dataclass(frozen=True)
class Trajectory:
    """Frame times (s), attitudes (one Rotation of N) and body rates (N x 3, deg/s);
    ``tag_times``: the time each frame is tagged with (None: its true time)."""

    times: np.ndarray
    rotations: Rotation
    rates_dps: np.ndarray
    tag_times: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.times)


def constant_rate(r0: Rotation, rate_dps, fps: float, count: int,
                  first: int = 0) -> Trajectory:
    """``count`` frames at ``fps`` turning at the body rate ``rate_dps`` (camera frame),
    from frame ``first`` of the sequence on."""
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be a positive number, got {fps}")
    w = np.radians(np.asarray(rate_dps, dtype=np.float64)).reshape(3)
    times = (first + np.arange(int(count), dtype=np.float64)) / float(fps)
    rotations = r0 * Rotation.from_rotvec(times[:, None] * w[None, :])
    rates = np.tile(np.degrees(w), (len(times), 1))
    return Trajectory(times, rotations, rates)


@dataclass(frozen=True)
class Profile:
    """An attitude profile: strictly increasing times (s) and the attitude at each."""

    times: np.ndarray
    rotations: Rotation

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def at(self, times: np.ndarray) -> Rotation:
        """Attitudes at ``times`` by SLERP between the profile's samples."""
        times = np.asarray(times, dtype=np.float64)
        lo, hi = self.times[0], self.times[-1]
        if np.any(times < lo - 1e-9) or np.any(times > hi + 1e-9):
            raise InputError(f"profile covers t = {lo} to {hi} s; asked for "
                             f"{times.min()} to {times.max()} s")
        return Slerp(self.times, self.rotations)(np.clip(times, lo, hi))

    def rate_at(self, times: np.ndarray, dt: float) -> np.ndarray:
        """Body rates (N x 3, deg/s, camera frame) over ``dt`` centred on each time."""
        times = np.asarray(times, dtype=np.float64)
        a = self.at(np.clip(times - dt / 2, self.times[0], self.times[-1]))
        b = self.at(np.clip(times + dt / 2, self.times[0], self.times[-1]))
        span = (np.clip(times + dt / 2, self.times[0], self.times[-1])
                - np.clip(times - dt / 2, self.times[0], self.times[-1]))
        rotvec = (a.inv() * b).as_rotvec().reshape(-1, 3)
        return np.degrees(rotvec / np.where(span > 0, span, 1.0)[:, None])


def read_profile(path: str | Path) -> Profile:
    """Read a profile CSV (``t,qw,qx,qy,qz``); every error names the file and line."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read profile ({exc})") from None
    reader = csv.DictReader(text.splitlines())
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in PROFILE_COLUMNS if c not in header]
    if missing:
        raise InputError(f"{path}: profile needs columns {','.join(PROFILE_COLUMNS)} "
                         f"(missing {','.join(missing)})")
    reader.fieldnames = header
    rows = []
    for line, row in enumerate(reader, start=2):
        try:
            values = [float(row[c]) for c in PROFILE_COLUMNS]
        except (TypeError, ValueError):
            raise InputError(f"{path}:{line}: expected numbers in "
                             f"{','.join(PROFILE_COLUMNS)}") from None
        if not all(math.isfinite(v) for v in values):
            raise InputError(f"{path}:{line}: values must be finite")
        if np.linalg.norm(values[1:]) < 1e-6:
            raise InputError(f"{path}:{line}: quaternion has zero length")
        rows.append(values)
    return _profile_from_rows(np.array(rows).reshape(-1, 5), path)


def _profile_from_rows(data: np.ndarray, path: Path) -> Profile:
    if len(data) < 2:
        raise InputError(f"{path}: a profile needs at least two rows")
    times = data[:, 0]
    if np.any(np.diff(times) <= 0):
        line = int(np.flatnonzero(np.diff(times) <= 0)[0]) + 3
        raise InputError(f"{path}:{line}: times must increase strictly")
    q = data[:, 1:] / np.linalg.norm(data[:, 1:], axis=1, keepdims=True)
    return Profile(times, Rotation.from_quat(q, scalar_first=True))


def profile_frames(profile: Profile, fps: float, count: int | None = None) -> int:
    """How many frames at ``fps`` the profile gives: ``count`` if it covers them."""
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be a positive number, got {fps}")
    available = int(math.floor(profile.duration * fps + 1e-9)) + 1
    count = available if count is None else int(count)
    if count > available:
        raise InputError(f"profile lasts {profile.duration:g} s: {available} frame(s) at "
                         f"{fps:g} fps, not {count}")
    return count


def profile_trajectory(profile: Profile, fps: float, count: int | None = None,
                       first: int = 0) -> Trajectory:
    """Frames at ``fps`` from the profile's first time; ``count`` frames (default: as many
    as the profile covers) from frame ``first`` on. The rate of each frame is taken over
    one frame interval."""
    count = profile_frames(profile, fps, None if count is None else first + count) - first
    times = profile.times[0] + (first + np.arange(count, dtype=np.float64)) / fps
    return Trajectory(times - profile.times[0], profile.at(times),
                      profile.rate_at(times, 1.0 / fps))


@dataclass(frozen=True)
class SequencePlan:
    """The frames of a simulated sequence, computed a block at a time so that a sequence
    of any length takes bounded memory: a profile, else a constant rate from ``r0``."""

    count: int
    fps: float
    r0: Rotation
    rate_dps: tuple[float, float, float]
    profile: Profile | None = None
    #: 1 sigma of each frame's time-tag error (s), and the seed it is drawn from
    time_tag_error_s: float = 0.0
    seed: int = 0

    def __len__(self) -> int:
        return self.count

    def block(self, first: int, count: int) -> Trajectory:
        """Frames ``first`` to ``first + count - 1`` (fewer at the end)."""
        count = max(0, min(count, self.count - first))
        if self.profile is not None:
            block = profile_trajectory(self.profile, self.fps, count, first=first)
        else:
            block = constant_rate(self.r0, self.rate_dps, self.fps, count, first=first)
        if not self.time_tag_error_s:
            return block
        errors = time_tag_errors(self.seed, first, len(block), self.time_tag_error_s)
        return dataclasses.replace(block, tag_times=block.times + errors)


#: the purpose of the time-tag stream, beside a frame's scene (0) and effects (1) streams
_TIME_TAG_STREAM = 2


def time_tag_errors(seed: int, first: int, count: int, sigma_s: float) -> np.ndarray:
    """The time-tag errors (s) of frames ``first`` .. ``first + count - 1``: one normal
    per frame from its own stream (seed, frame, 2), so a frame's error never depends on
    the block it is computed in."""
    return np.array([np.random.default_rng([seed, first + k, _TIME_TAG_STREAM])
                     .standard_normal() for k in range(count)]) * float(sigma_s)


def simulation_trajectory(r0: Rotation, rate_dps, fps: float | None, profile_path,
                          count: int | None, time_tag_error_s: float = 0.0,
                          seed: int = 0) -> SequencePlan | None:
    """The frames of ``startrack simulate``: a profile file (``--profile``) at ``fps``, a
    constant rate from ``r0`` (``--fps`` with ``--rate``, or none: a stare), or None when
    there is no ``--fps`` (independent frames, as before). ``time_tag_error_s``: 1 sigma of
    the frames' time-tag errors, drawn from ``seed`` (a sequence's frames only)."""
    if fps is None:
        if profile_path is not None:
            raise InputError("--profile needs --fps (the frame rate to sample it at)")
        if time_tag_error_s:
            raise InputError("[frames] time_tag_error_s needs a sequence (--fps): "
                             "independent frames have no time")
        return None
    tag = {"time_tag_error_s": float(time_tag_error_s), "seed": int(seed)}
    if profile_path is not None:
        if rate_dps is not None:
            raise InputError("--rate and --profile exclude each other")
        profile = read_profile(profile_path)
        return SequencePlan(profile_frames(profile, fps, count), fps, r0, (0.0, 0.0, 0.0),
                            profile, **tag)
    return SequencePlan(3 if count is None else count, fps, r0,
                        tuple(rate_dps or (0.0, 0.0, 0.0)), **tag)
