"""Matchers, registered by name: each module in this package adds one method."""

from __future__ import annotations

import importlib
import pkgutil

from startrack.errors import InputError
from startrack.matchers.base import Matcher, MatcherConfig, register, registry

_loaded = False


def _load_all() -> None:
    global _loaded
    if _loaded:
        return
    for info in pkgutil.iter_modules(__path__):
        if info.name != "base" and not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
    _loaded = True


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


__all__ = ["Matcher", "MatcherConfig", "available_methods", "get_matcher", "register"]
