"""startrack: a star-tracker simulator and star-identification bench.

``startrack.solve(...)`` and ``startrack.Solver(...)`` are the Python API
(docs/conventions.md); they are imported on first use so that ``import startrack``
and the command line start fast.
"""

from startrack import _numba_cache

_numba_cache.configure()  # before any module imports numba

__version__ = "0.1.0"

__all__ = ["Solver", "SolveResult", "solve", "__version__"]


def __getattr__(name: str):
    if name in ("Solver", "SolveResult", "solve"):
        from startrack import api  # numpy, scipy, pandas: `import startrack` and --help stay light

        return getattr(api, name)
    raise AttributeError(f"module 'startrack' has no attribute {name!r}")
