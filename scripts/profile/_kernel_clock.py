"""How much of a solve runs inside the compiled core: clocks wrapped around its entry
points (scripts/profile/profile_identify.py --kernels, scripts/bench/bench_floor.py).

Every compiled function a startrack Python module calls (the pattern searches, the camera
fits, the evidence refit and its catalog scan, the cone lookups, a frame's verifier
set-up...) is replaced, where the module looks it up, by a wrapper that adds its wall time
to a clock named after it; so are the two calls made through compiled objects that take
most of a frame (a verification, ``FrameVerifier.check``; a nominal FOV's fitted rounds,
``FittedRounds.run`` and ``pattern_focal``). What is left of a frame's time is Python:
the pipeline, the glue between the calls, the objects they return (and the few compiled
calls made through other compiled objects). The wrappers cost about 0.25 us a call,
counted inside the core, so its share is a little overstated.
"""

from __future__ import annotations

import sys
import time
import types

import startrack.solver._fov_fit as fov_fit
from startrack.verify import FrameVerifier


class KernelClock:
    """The time spent inside compiled kernels since the last :meth:`take`: every compiled
    function a startrack Python module calls, wrapped where it is looked up."""

    def __init__(self) -> None:
        self.spent = 0.0
        self.by_kernel: dict[str, list[float]] = {}  # name: [seconds, calls] while counted
        self.counting = self.installed = False
        self._wrapped: set[int] = set()
        self._replaced: list[tuple[object, str, object]] = []  # (where, name, original)

    def take(self) -> float:
        """The time inside kernels since the last take."""
        spent, self.spent = self.spent, 0.0
        return spent

    def timed(self, fn, name: str | None = None):
        """``fn`` with its calls' time added to this clock (under ``name`` while
        counting)."""
        clock, name = time.perf_counter, name or getattr(fn, "__qualname__", repr(fn))
        held = self.by_kernel.setdefault(name, [0.0, 0])

        def run(*args, **kwargs):
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                dt = clock() - t0
                self.spent += dt
                if self.counting:
                    held[0] += dt
                    held[1] += 1
        run.__wrapped__ = fn
        return run

    def breakdown(self, solves: int, top: int = 6) -> str:
        """The kernels that took most while counting, their mean per solve over
        ``solves`` (a slow frame weighs in: a median per kernel would not add up), and
        the counts reset."""
        ranked = sorted(self.by_kernel.items(), key=lambda kv: -kv[1][0])
        text = ", ".join(f"{name.removeprefix('startrack._core.')} "
                         f"{held[0] / solves * 1e6:.0f} us ({held[1] / solves:.1f} calls)"
                         for name, held in ranked[:top] if held[1])
        calls = sum(held[1] for held in self.by_kernel.values()) / solves
        for held in self.by_kernel.values():
            held[0], held[1] = 0.0, 0
        return f"{calls:.0f} timed calls a solve; the most time: {text}"

    def install(self) -> None:
        """Wrap every compiled function the loaded startrack modules call, and the two
        extension-type calls the solver makes most (the verification, the fitted
        rounds)."""
        for module in _startrack_modules():
            for attr, value in list(vars(module).items()):
                if _compiled(value):
                    self._replace(module, attr, self.timed(value, f"{value.__module__}.{attr}"))
                elif isinstance(value, types.ModuleType) and \
                        value.__name__.startswith("startrack._core."):
                    self._wrap_module(value)
        self._replace(FrameVerifier, "check", self.timed(FrameVerifier.check, "Verifier.check"))
        rounds_for = fov_fit.rounds_for

        def timed_rounds(*args, **kwargs):
            return _TimedRounds(rounds_for(*args, **kwargs), self)

        for module in _startrack_modules():  # wherever it was imported by name
            if getattr(module, "rounds_for", None) is rounds_for:
                self._replace(module, "rounds_for", timed_rounds)
        self.installed = True

    def uninstall(self) -> None:
        """Every wrapped name back as it was."""
        while self._replaced:
            where, name, original = self._replaced.pop()
            setattr(where, name, original)
        self._wrapped.clear()
        self.installed = False

    def _replace(self, where, name: str, value) -> None:
        self._replaced.append((where, name, getattr(where, name)))
        setattr(where, name, value)

    def _wrap_module(self, module: types.ModuleType) -> None:
        if id(module) in self._wrapped:
            return
        self._wrapped.add(id(module))
        for attr, value in list(vars(module).items()):
            if _compiled(value):
                self._replace(module, attr, self.timed(value, f"{module.__name__}.{attr}"))


class _TimedRounds:
    """A FittedRounds whose runs and pattern fits are timed."""

    def __init__(self, rounds, clock: KernelClock) -> None:
        self.run = clock.timed(rounds.run, "FittedRounds.run")
        self.pattern_focal = clock.timed(rounds.pattern_focal, "FittedRounds.pattern_focal")


def _startrack_modules() -> list[types.ModuleType]:
    """The loaded Python modules of startrack (not its compiled core)."""
    return [module for name, module in list(sys.modules.items())
            if module is not None and name.startswith("startrack.")
            and not name.startswith("startrack._core")]


def _compiled(value) -> bool:
    """A Cython function of a startrack._core module (not a class or a constant)."""
    return (type(value).__name__ in ("cython_function_or_method", "builtin_function_or_method")
            and str(getattr(value, "__module__", "")).startswith("startrack._core"))


#: the clock profile_identify.py installs (counting every call)
CLOCK = KernelClock()


def install() -> None:
    """Wrap the entry points of the loaded modules (once per process), every call
    counted."""
    CLOCK.install()
    CLOCK.counting = True


def reset() -> None:
    for held in CLOCK.by_kernel.values():
        held[0], held[1] = 0.0, 0
    CLOCK.take()


def report(frames: int, total_ms: float) -> str:
    """The clocks per frame, and the compiled share of ``total_ms`` (all frames)."""
    ranked = sorted(CLOCK.by_kernel.items(), key=lambda kv: -kv[1][0])
    lines = [f"{'compiled entry point':48s} {'us/frame':>9s} {'calls/frame':>12s}"]
    lines += [f"{name.removeprefix('startrack._core.'):48s} {held[0] / frames * 1e6:9.1f} "
              f"{held[1] / frames:12.2f}" for name, held in ranked if held[1]]
    inside = sum(held[0] for held in CLOCK.by_kernel.values()) * 1000.0
    lines.append(f"{'all compiled entry points':48s} {inside / frames * 1000:9.1f}")
    lines.append(f"{'the whole identify (mean)':48s} {total_ms / frames * 1000:9.1f}")
    lines.append(f"compiled share {inside / total_ms:.0%}; the rest is Python")
    return "\n".join(lines)
