"""The Python API of docs/conventions.md: ``startrack.solve(...)`` and ``startrack.Solver``,
answering with a :class:`SolveResult`."""

from startrack._lazy import lazy_exports

__all__ = [
    "STAR_COLUMNS", "SequenceChoice", "SolveResult", "Solver", "SolverRequest", "as_frame_input",
    "build_solver", "preset", "solve",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "STAR_COLUMNS": "_result",
    "SequenceChoice": "_build",
    "SolverRequest": "_build",
    "build_solver": "_build",
    "preset": "_build",
    "SolveResult": "_result",
    "Solver": "_solver",
    "as_frame_input": "_solver",
    "solve": "_solver",
})
