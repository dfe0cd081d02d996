"""How much of an identify runs inside the compiled core: clocks wrapped around its entry
points (scripts/profile/profile_identify.py --kernels).

Each entry point the solver calls per frame (the quad and pyramid searches, the camera
fit, a nominal FOV's fit-and-verify rounds, a verification, a frame's verifier set-up, a
camera's chi-square) is replaced, where the solver looks it up, by a wrapper that adds
its wall time to a named clock. What is left of a frame's time is Python: the pipeline,
the glue between the calls, the objects they return. The wrappers cost about 0.3 us a
call, so the compiled share is a little overstated.
"""

from __future__ import annotations

import time
from collections import defaultdict

import startrack._core.matchers.pyramid as pyramid_core

import startrack.matchers._quad as quad
import startrack.solver._fov_fit as fov_fit
import startrack.solver._fov_given as fov_given
import startrack.verify._frame as frame_verifier

SECONDS: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)


def _clocked(function, name: str):
    def clocked(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            SECONDS[name] += time.perf_counter() - t0
            CALLS[name] += 1
    return clocked


class _ClockedMethods:
    """An object whose named methods are clocked (for a compiled class, which cannot be
    patched)."""

    def __init__(self, inner, names: dict[str, str]) -> None:
        self._inner = inner
        for method, name in names.items():
            setattr(self, method, _clocked(getattr(inner, method), name))

    def __getattr__(self, attr):
        return getattr(self._inner, attr)


def _clocked_class(cls, name: str, methods: dict[str, str]):
    def make(*args, **kwargs):
        t0 = time.perf_counter()
        inner = cls(*args, **kwargs)
        SECONDS[name] += time.perf_counter() - t0
        CALLS[name] += 1
        return _ClockedMethods(inner, methods)
    return make


def _clocked_rounds(cls):
    """The fitted rounds' class, each frame's copy (``with_pixels``) clocked as its
    set-up and its calls as the rounds and the pattern's camera fit."""
    methods = {"run": "fitted rounds: run", "pattern_focal": "camera fit (pattern_focal)"}

    class Template:
        def __init__(self, *args, **kwargs) -> None:
            self._inner = cls(*args, **kwargs)

        def with_pixels(self, x, y):
            t0 = time.perf_counter()
            copy = self._inner.with_pixels(x, y)
            SECONDS["fitted rounds: set-up"] += time.perf_counter() - t0
            CALLS["fitted rounds: set-up"] += 1
            return _ClockedMethods(copy, methods)

    return Template


def install() -> None:
    """Wrap the entry points (once per process)."""
    quad.first_confirmed = _clocked(quad.first_confirmed, "quad search (first_confirmed)")
    pyramid_core.search = _clocked(pyramid_core.search, "pyramid search")
    fov_fit.fit_focal_kernel = _clocked(fov_fit.fit_focal_kernel, "camera fit (fit_focal)")
    fov_given.squared_residuals = _clocked(fov_given.squared_residuals,
                                           "camera chi-square (squared_residuals)")
    fov_given.fit_against = _clocked(fov_given.fit_against,
                                     "camera fit and chi-squares (fit_against)")
    fov_fit.FittedRounds = _clocked_rounds(fov_fit.FittedRounds)
    frame_verifier.Frame = _clocked(frame_verifier.Frame, "verifier: frame set-up")
    frame_verifier.Verifier = _clocked_class(frame_verifier.Verifier,
                                             "verifier: set-up", {"check": "verification"})


def reset() -> None:
    SECONDS.clear()
    CALLS.clear()


def report(frames: int, total_ms: float) -> str:
    """The clocks per frame, and the compiled share of ``total_ms`` (all frames)."""
    lines = [f"{'compiled entry point':40s} {'us/frame':>9s} {'calls/frame':>12s}"]
    for name in sorted(SECONDS, key=SECONDS.get, reverse=True):
        lines.append(f"{name:40s} {SECONDS[name] / frames * 1e6:9.1f} "
                     f"{CALLS[name] / frames:12.2f}")
    inside = sum(SECONDS.values()) * 1000.0
    lines.append(f"{'all compiled entry points':40s} {inside / frames * 1000:9.1f}")
    lines.append(f"{'the whole identify (mean)':40s} {total_ms / frames * 1000:9.1f}")
    lines.append(f"compiled share {inside / total_ms:.0%}; the rest is Python")
    return "\n".join(lines)
