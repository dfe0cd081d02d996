"""What every frame solver offers its front doors (``identify``, the Python API, the bench):
a single-frame :class:`~startrack.solver.Pipeline` and a sequence's
:class:`~startrack.tracking.SequenceSolver` alike."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from startrack.solver._identifier import FrameResult
from startrack.solver._inputs import FrameInput
from startrack.solver._options import Options


class FrameSolver(Protocol):
    """Solves frames one after another with fixed options."""

    options: Options

    def solve(self, frame: FrameInput) -> FrameResult:
        """Solve one frame, already read."""

    def run(self, path: str | Path) -> FrameResult:
        """Read ``path`` (an image or a centroid CSV) and solve it."""

    def skip(self) -> None:
        """A frame that could not be read (in a sequence, time passes without a solution)."""

    def reset(self) -> None:
        """Forget every earlier frame: the next is solved lost-in-space."""


__all__ = ["FrameSolver"]
