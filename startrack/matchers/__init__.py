"""Matchers, registered by name: each module of this package adds one method (the shared
machinery sits in ``_shared/``), and other packages add theirs through the
``startrack.matchers`` entry point group."""

from __future__ import annotations

import importlib
import pkgutil
import warnings
from importlib.metadata import entry_points

from startrack._lazy import lazy_exports
from startrack.errors import InputError, StartrackWarning
from startrack.matchers._base import Matcher, MatcherConfig, register, registry

#: the entry point group a package declares its matchers in (docs/conventions.md)
ENTRY_POINT_GROUP = "startrack.matchers"

_loaded = False


def _load_all() -> None:
    global _loaded
    if _loaded:
        return
    for info in pkgutil.iter_modules(__path__):
        if not info.ispkg and info.name != "_base":  # a method's module registers it
            importlib.import_module(f"{__name__}.{info.name}")
    _loaded = True  # before the plugins: a plugin importing this package must not recurse
    _load_plugins()


def _load_plugins() -> None:
    """Register the matchers other packages declare, e.g. in their pyproject.toml::

        [project.entry-points."startrack.matchers"]
        my_method = "my_package.module:MyMatcher"

    The object named is a :class:`Matcher` subclass (registered here under its ``name``)
    or a module whose import registers its matchers with :func:`register`. A plugin that
    fails to load, or takes a name already used, is skipped with a one-line warning: one
    broken package must not stop every command."""
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            loaded = ep.load()
            if isinstance(loaded, type):
                if not issubclass(loaded, Matcher):
                    raise TypeError(f"{loaded.__qualname__} is not a startrack Matcher")
                register(loaded)
        except Exception as exc:  # noqa: BLE001 - any error of foreign code is a warning
            warnings.warn(f"matcher plugin {ep.name!r} ({ep.value}) not loaded: "
                          f"{type(exc).__name__}: {exc}", StartrackWarning, stacklevel=2)


def available_methods() -> list[str]:
    _load_all()
    return sorted(registry())


def get_matcher(name: str) -> type[Matcher]:
    _load_all()
    try:
        return registry()[name]
    except KeyError:
        raise InputError(f"unknown method {name!r} (choose from: "
                         f"{', '.join(available_methods())})") from None


__all__ = [
    "angle_table", "attitude_from_tetra3", "attitude_from_tetra3rs", "available_methods",
    "ENTRY_POINT_GROUP", "get_matcher", "IMAGE_STARS", "INSTALL", "Matcher", "MatcherConfig",
    "positions_to_indices", "QuadMatcher", "register", "ScaledHypothesis", "solve_field",
    "solve_field_available", "tetra3_centroids", "tetra3rs_centroids", "write_gaia_binary",
    "write_hip_main",
]

# Other stages' entry points, each imported on first use.
__getattr__, __dir__ = lazy_exports(__name__, {
    "angle_table": "_shared.geometry",
    "attitude_from_tetra3": "_tetra3",
    "attitude_from_tetra3rs": "_tetra3rs",
    "IMAGE_STARS": "_quad",
    "INSTALL": "_astrometry",
    "positions_to_indices": "_shared.peer",
    "QuadMatcher": "_quad",
    "ScaledHypothesis": "_quad",
    "solve_field": "_astrometry",
    "solve_field_available": "_astrometry",
    "tetra3_centroids": "_tetra3",
    "tetra3rs_centroids": "_tetra3rs",
    "write_gaia_binary": "_shared.peer",
    "write_hip_main": "_shared.peer",
})
