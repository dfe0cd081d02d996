"""Matchers, registered by name: each module in this package adds one method, and other
packages add theirs through the ``startrack.matchers`` entry point group."""

from __future__ import annotations

import importlib
import pkgutil
import warnings
from importlib.metadata import entry_points

from startrack.errors import InputError, StartrackWarning
from startrack.matchers.base import Matcher, MatcherConfig, register, registry

#: the entry point group a package declares its matchers in (docs/conventions.md)
ENTRY_POINT_GROUP = "startrack.matchers"

_loaded = False


def _load_all() -> None:
    global _loaded
    if _loaded:
        return
    for info in pkgutil.iter_modules(__path__):
        if info.name != "base" and not info.name.startswith("_"):
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


__all__ = ["ENTRY_POINT_GROUP", "Matcher", "MatcherConfig", "available_methods",
           "get_matcher", "register"]
