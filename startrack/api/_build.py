"""The one assembly of a frame solver: what ``startrack identify``, the Python API or a
config was told, decided into a pipeline (and a sequence solver around it for ``--track``
or ``--prior``). Both front doors call :func:`build_solver`; neither assembles its own."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from startrack.defaults import DEFAULT_PRIOR_SIGMA_DEG
from startrack.simulate import load_config
from startrack.solver import FrameSolver, Options, Pipeline
from startrack.tracking import SequenceSolver, prior_from_radec_roll


@dataclass(frozen=True)
class SequenceChoice:
    """How frames relate: one sequence tracked frame to frame, and/or a prior attitude."""

    track: bool = False
    #: (ra, dec, roll) in degrees: seeds the first frame of a sequence, or every frame
    prior: tuple[float, float, float] | None = None
    prior_sigma_deg: float = DEFAULT_PRIOR_SIGMA_DEG


@dataclass(frozen=True)
class SolverRequest:
    """Everything a front door was told, already checked and converted."""

    options: Options
    #: a TOML preset whose [camera] and [sky] are the defaults the options override
    config: str | Path | None = None
    sequence: SequenceChoice = SequenceChoice()


def preset(config: str | Path | None, camera, fov_deg: float | None, hints):
    """(camera, sky) of a ``--config`` preset: its camera unless a camera, a field of view
    or a scale range is given; its sky (which ``--sky`` and ``--mag-limit`` override).
    (camera, None) without a preset."""
    if config is None:
        return camera, None
    loaded = load_config(config)
    own_scale = hints is not None and hints.scale is not None
    if camera is None and fov_deg is None and not own_scale:
        camera = loaded.camera
    return camera, loaded.sky


def with_preset(options: Options, config: str | Path | None) -> Options:
    """``options`` with a preset's camera and sky (:func:`preset`)."""
    if config is None:
        return options
    camera, sky = preset(config, options.camera, options.fov_deg, options.hints)
    return dataclasses.replace(options, camera=camera, sky_spec=sky)


def build_solver(request: SolverRequest) -> FrameSolver:
    """The solver of ``request``: a :class:`~startrack.solver.Pipeline`, or with ``track``
    or a ``prior`` a :class:`~startrack.tracking.SequenceSolver` around one."""
    pipeline = Pipeline(with_preset(request.options, request.config))
    seq = request.sequence
    if not seq.track and seq.prior is None:
        return pipeline
    prior = None if seq.prior is None else prior_from_radec_roll(*seq.prior,
                                                                  seq.prior_sigma_deg)
    return SequenceSolver(pipeline, track=seq.track, prior=prior)


__all__ = ["SequenceChoice", "SolverRequest", "build_solver", "preset", "with_preset"]
