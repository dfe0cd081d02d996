"""What `startrack compare` was told, as records: the levels typed, the run folder, and
which of its four modes runs (one dispatch in ``_compare.py``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path

import click

from startrack.errors import InputError
from startrack.input_checks import FALSE_STARS


@dataclass(frozen=True)
class LevelTexts:
    """Each condition axis as typed (comma-separated levels, first = base); None: default."""

    noise_px: str | None = None
    false_stars: str | None = None
    missing: str | None = None
    mag_noise: str | None = None
    fov_error: str | None = None
    distortion_k1: str | None = None
    modelled_k1: str | None = None
    rates: str | None = None
    cosmic_rays: str | None = None
    stray_light: str | None = None
    temperature_c: str | None = None
    colour_index: str | None = None


@dataclass(frozen=True)
class FolderChoice:
    """Where the run writes (None: a new dated folder) and how it meets an earlier run."""

    out_dir: str | None = None
    resume: bool | None = None
    overwrite: bool = False


@dataclass(frozen=True)
class CompareRequest:
    """One `startrack compare` invocation."""

    methods: str
    config_path: str | None
    sky: str | None
    mag_limit: float | None
    frames: int
    grid: str
    max_stars: int
    source: str
    threshold_arcsec: float
    jobs: int | None
    scheduler: str | None
    seed: int | None
    mode: str
    fps: float
    replay: str | None
    frames_dir: str | None
    levels: LevelTexts
    folder: FolderChoice
    quiet: bool = False
    verbose: bool = False

    @classmethod
    def from_options(cls, given: dict) -> CompareRequest:
        """The records of the command's keyword values (each option once)."""
        given = dict(given)
        levels = LevelTexts(**{f.name: given.pop(f.name) for f in fields(LevelTexts)})
        folder = FolderChoice(**{f.name: given.pop(f.name) for f in fields(FolderChoice)})
        return cls(levels=levels, folder=folder, **given)

    @property
    def run_mode(self) -> str:
        """Which mode runs (a key of ``_compare.RUNNERS``): a folder of frames, sequences,
        one replayed unit, else the Monte Carlo run."""
        if self.frames_dir is not None:
            return "frames_dir"
        if self.mode == "tracking":
            return "tracking"
        return "replay" if self.replay is not None else "lost_in_space"




@dataclass
class CompareRun:
    """A comparison under way: the request, its methods, its folder, and how it talks."""

    request: CompareRequest
    methods: tuple[str, ...]
    out_dir: Path
    note: Callable[[str], None]
    detail: Callable[[str], None]
    #: once the run holds ``out_dir``: names it and points ``latest`` at it
    started: Callable[[], None]
    #: ``finish(result, replay_for=None)`` writes report.md, appending its path to ``reports``
    finish: Callable
    reports: list = field(default_factory=list)


DEFAULT_LEVELS = {"noise_px": "0,0.5,1,2", "false_stars": "0,1,3,5", "missing": "0",
                  "mag_noise": "0", "fov_error": "0", "distortion_k1": "0",
                  "modelled_k1": "0"}


def _effect_levels(given: tuple, effects, source: str) -> dict[str, tuple]:
    """The effect axes' levels from the options' texts (``given``, in EFFECT_OPTIONS'
    order), else the config's one level; an effect needs rendered frames."""
    from startrack.bench import is_default, parse_values
    from startrack.cli._effect_options import EFFECT_OPTIONS, effect_bounds

    config = {"cosmic_rays": effects.environment.cosmic_rays,
              "stray_light": effects.environment.stray_light,
              "temperature_c": effects.detector.temperature_c}
    levels = {}
    for (option, param, *_), text in zip(EFFECT_OPTIONS, given, strict=True):
        bounds = effect_bounds(param)
        levels[param] = (parse_values(text, option, low=bounds.low, high=bounds.high)
                         if text is not None else (config[param],))
        if source != "images" and any(not is_default(param, v) for v in levels[param]):
            raise InputError(f"{option} acts on rendered frames: give --from images")
    return levels


def _colour_levels(text: str | None, effects, source: str) -> tuple:
    """The star-colour axis's levels (B-V; none given: the Sun-like base, no colour). A
    colour acts through the band's curves and on rendered frames only."""
    from startrack.bench import parse_values
    from startrack.cli._effect_options import COLOUR_INDEX_RANGE
    from startrack.simulate import REFERENCE_BV

    if text is None:
        return (REFERENCE_BV,)
    low, high = COLOUR_INDEX_RANGE
    values = parse_values(text, "--colour-index", low=low, high=high)
    if all(v == REFERENCE_BV for v in values):
        return values
    if source != "images":
        raise InputError("--colour-index acts on rendered frames: give --from images")
    if effects.band.is_off:
        raise InputError("--colour-index acts through the band: give a --config with a "
                         "[band] table (filter and QE curves, docs/simulation.md)")
    return values


def _levels(noise_px, false_stars, missing, mag_noise, source: str,
            camera_levels: dict | None = None) -> dict[str, tuple]:
    from startrack.bench import parse_values

    if source == "images":
        if noise_px is not None:
            click.echo("note: --noise-px does not apply to --from images (the sensor model "
                       "sets the pixel noise); ignored", err=True)
        noise_px = "0"
    given = {"noise_px": noise_px, "false_stars": false_stars, "missing": missing,
             "mag_noise": mag_noise, "fov_error": None, "distortion_k1": None,
             "modelled_k1": None, **(camera_levels or {})}
    text = {k: DEFAULT_LEVELS[k] if v is None else v for k, v in given.items()}
    return {
        "noise_px": parse_values(text["noise_px"], "--noise-px"),
        "false_stars": parse_values(text["false_stars"], "--false-stars", integer=True,
                                     high=FALSE_STARS.high),
        "missing": parse_values(text["missing"], "--missing", high=1.0),
        "mag_noise": parse_values(text["mag_noise"], "--mag-noise"),
        "fov_error": parse_values(text["fov_error"], "--fov-error", low=-0.5, high=0.5),
        "distortion_k1": parse_values(text["distortion_k1"], "--distortion", low=-1.0,
                                      high=1.0),
        "modelled_k1": parse_values(text["modelled_k1"], "--modelled-distortion", low=-1.0,
                                    high=1.0),
    }


def condition_levels(levels: LevelTexts, source: str, effects) -> dict[str, tuple]:
    """Every condition axis's levels (a lost-in-space run): the typed ones parsed, the
    others their defaults (the effects: the config's)."""
    return _levels(levels.noise_px, levels.false_stars, levels.missing, levels.mag_noise,
                   source, dict(fov_error=levels.fov_error,
                                distortion_k1=levels.distortion_k1,
                                modelled_k1=levels.modelled_k1)) | \
        _effect_levels((levels.cosmic_rays, levels.stray_light, levels.temperature_c),
                       effects, source) | \
        {"colour_index": _colour_levels(levels.colour_index, effects, source)}


__all__ = ["DEFAULT_LEVELS", "CompareRequest", "CompareRun", "FolderChoice",
           "LevelTexts", "condition_levels"]
