"""Package re-exports resolved on first use, so that importing one light module of a stage
(or running ``--help``) never loads the stage's heavy neighbours (numpy kernels, astropy,
OpenCV)."""

from __future__ import annotations

import importlib
from collections.abc import Callable


def lazy_exports(package: str, exports: dict[str, str]) -> tuple[Callable, Callable]:
    """``(__getattr__, __dir__)`` for a package that re-exports ``name`` from its private
    module ``exports[name]`` (PEP 562).

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict of str to str
        Public name -> the private module (relative to ``package``) that defines it.

    Returns
    -------
    tuple of callable
        The package's ``__getattr__`` and ``__dir__``.
    """

    def __getattr__(name: str):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
        globals_of_package = importlib.import_module(package).__dict__
        globals_of_package[name] = value  # later lookups skip this function
        return value

    def __dir__() -> list[str]:
        return sorted(exports)

    return __getattr__, __dir__
