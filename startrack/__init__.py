"""startrack: a star-tracker simulator and star-identification bench.

The public API (docs/api.md): ``startrack.solve(...)`` and ``startrack.Solver(...)`` answer
frames with a :class:`SolveResult`; :class:`Camera`, :func:`load_sky`,
:func:`extract_centroids`, :class:`Matcher` and :func:`register` are the stages they are
built from. Each is imported on first use, so that ``import startrack`` and the command
line start fast.
"""

from startrack._lazy import lazy_exports

__version__ = "0.1.0"

__all__ = [
    "Camera", "Matcher", "SolveResult", "Solver", "__version__", "extract_centroids",
    "load_sky", "register", "solve",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Camera": "camera",
    "Matcher": "matchers",
    "SolveResult": "api",
    "Solver": "api",
    "extract_centroids": "centroids",
    "load_sky": "sky",
    "register": "matchers",
    "solve": "api",
})
