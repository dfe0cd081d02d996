"""What an input's record says about how it was solved: the request as the user made it
(method, sky, field of view, hints) and every stage tried for it, in order, with what
each answered, so a fallback's answer is never mistaken for the method that was asked.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass, field

from startrack.sky import SkySpec

#: the sky keys that describe only a random sky (its size and seed)
RANDOM_SKY_KEYS = ("n_stars", "seed")


def sky_text(sky: SkySpec | dict | None) -> str:
    """A sky in a few words: "hipparcos to mag 6.5", "gaia (cut per field)", "random"."""
    if sky is None:
        return "-"
    spec = sky.to_dict() if isinstance(sky, SkySpec) else sky
    kind = str(spec.get("kind", "random"))
    if kind == "file":
        kind = f"file {spec.get('path')}"
    limit = spec.get("mag_limit")
    if kind == "random":
        return f"random ({spec.get('n_stars')} stars, seed {spec.get('seed')})"
    return f"{kind} to mag {limit:g}" if limit is not None else kind


def sky_record(source: SkySpec | dict) -> dict:
    """A sky's specification as a record holds it (``diagnostics.sky``, ``requested.sky``):
    a real catalog's without the random sky's size and seed. A new dict each time."""
    if isinstance(source, SkySpec):
        return dict(_sky_items(source))
    if source.get("kind", "random") == "random":
        return source
    return {k: v for k, v in source.items() if k not in RANDOM_SKY_KEYS}


@functools.lru_cache(maxsize=64)
def _sky_items(sky: SkySpec) -> tuple:
    """:func:`sky_record`'s items for a SkySpec, made once per sky (every input's
    request and stages name one)."""
    spec = sky.to_dict()
    if spec.get("kind", "random") != "random":
        spec = {k: v for k, v in spec.items() if k not in RANDOM_SKY_KEYS}
    return tuple(spec.items())


def hints_dict(hints) -> dict | None:
    """The hints used (:class:`startrack.solver._hints.Hints`) as a record holds them."""
    if hints is None or not hints:
        return None
    out: dict = {}
    if hints.pointing is not None:
        p = hints.pointing
        out.update(ra_deg=p.ra_deg, dec_deg=p.dec_deg, radius_deg=p.radius_deg)
    if hints.scale is not None:
        s = hints.scale
        out.update(scale_low=s.low, scale_high=s.high, scale_units=s.units)
        if s.pixel_um is not None:
            out["pixel_size_um"] = s.pixel_um
    out["from"] = "fits header" if hints.from_header else "user"
    return out


def request_record(options, decide, frame, hints=None) -> dict:
    """``requested`` of a record: the method asked for, the sky and field of view this
    input was given (``decide(frame)``: options, else its sidecar, else the defaults,
    decided again quietly: its warnings were given when it was first decided; an input
    with no path has no sidecar to warn of), the hints."""
    if frame.path is None:
        camera, sky = decide(frame)
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            camera, sky = decide(frame)
    out: dict = {"method": options.method, "sky": sky_record(sky)}
    if camera is None:
        out["fov_deg"] = None  # unknown: a blind search
    else:
        out["fov_deg"] = round(camera.fov_deg, 6)
        out["fov_tolerance"] = options.fov_tolerance
    if hints is not None and hints:
        out["hints"] = hints_dict(hints)
    return out


@dataclass
class Trail:
    """The stages one input went through, in order (reset for each input)."""

    steps: list[dict] = field(default_factory=list)

    def add(self, stage: str, method: str, sky: SkySpec | None, fov_deg, solution=None,
            result: str | None = None) -> None:
        """One stage: ``stage`` (what it was), the method and sky it used, the field of
        view it assumed (a value, or a searched (low, high) range in degrees) and its
        answer: ``solution``'s ("solved" or the reason it was not), else ``result``."""
        fov = (round(float(fov_deg), 4) if isinstance(fov_deg, int | float) else
               None if fov_deg is None else [round(float(v), 4) for v in fov_deg])
        if solution is not None:
            result = "solved" if solution.solved else (solution.reason or "no_match")
        self.steps.append({
            "stage": stage, "method": method,
            "sky": None if sky is None else sky_record(sky), "fov_deg": fov,
            "result": result,
            "ms": round(float(solution.identify_ms), 3) if solution is not None else 0.0})

    def take(self) -> tuple[dict, ...]:
        """The stages so far, now handed on (the trail starts again empty)."""
        steps, self.steps = tuple(self.steps), []
        return steps


def step_text(step: dict) -> str:
    """One stage as a line of the table output."""
    fov = step.get("fov_deg")
    fov_text = ("FOV unknown" if fov is None else f"FOV {fov[0]:g}-{fov[1]:g} deg"
                if isinstance(fov, list) else f"FOV {fov:g} deg")
    return (f"{step['stage']}: {step['method']} on {sky_text(step.get('sky'))}, {fov_text}: "
            f"{step['result']} ({step['ms']:.0f} ms)")


__all__ = ["RANDOM_SKY_KEYS", "Trail", "hints_dict", "request_record", "sky_record", "sky_text",
           "step_text"]
