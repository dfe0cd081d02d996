"""Where the files shipped beside the code are: data/ (star names) and configs/ (presets).

In a checkout they are the top-level folders beside the package; an installed copy has
them under ``<prefix>/share/startrack/`` (pyproject.toml's data-files).
"""

from __future__ import annotations

import site
import sys
from pathlib import Path

from startrack.errors import InputError

_KINDS = ("data", "configs")


def _roots() -> list[Path]:
    here = Path(__file__).resolve().parents[2]  # a checkout or an editable install
    prefixes = [sys.prefix, sys.base_prefix, getattr(site, "USER_BASE", None) or ""]
    return [here] + [Path(p) / "share" / "startrack" for p in prefixes if p]


def resource_path(kind: str, name: str) -> Path:
    """The path of shipped file ``name`` in ``kind`` ("data" or "configs").

    Raises InputError when no copy is found (a broken install)."""
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {_KINDS}, got {kind!r}")
    for root in _roots():
        path = root / kind / name
        if path.is_file():
            return path
    raise InputError(f"{kind}/{name}: not found beside the package or under "
                     f"{sys.prefix}/share/startrack (reinstall startrack)")


def preset_names() -> list[str]:
    """The shipped config presets (file stems), for help texts and errors."""
    for root in _roots():
        folder = root / "configs"
        if folder.is_dir():
            return sorted(p.stem for p in folder.glob("*.toml"))
    return []
