"""Library warnings and log lines kept off the user's stderr (installed at CLI entry).

numpy, astropy, erfa and tifffile speak through ``warnings`` and ``logging`` in their own
multi-line formats. A user of the command line sees only startrack's lines: a warning that
matters becomes one ``startrack: warning:`` line (each text once per run), the rest are
dropped; library log records go nowhere. docs/conventions.md lists the notes.
"""

from __future__ import annotations

import contextlib
import importlib.abc
import importlib.util
import logging
import sys
import warnings

import click

from startrack.errors import StartrackWarning

# Library warnings that tell the user something, by class name: the note printed instead.
NOTES = {
    "ErfaWarning": "a date far from the leap-second table: UTC is approximate there "
                   "(the aberration correction is unaffected at the arcsec level)",
}


def _note_for(message, category) -> str | None:
    """The one line to print for a warning, None to drop it."""
    if issubclass(category, StartrackWarning):
        return str(message)
    for cls in category.__mro__:
        if cls.__name__ in NOTES:
            return NOTES[cls.__name__]
    # numpy RuntimeWarnings, FITSFixedWarning, astropy's "File may have been truncated"
    # (startrack.io._images refuses such a file itself), ...: our own checks say what matters
    return None


def _show_warning(seen: set[str]):
    def showwarning(message, category, filename, lineno, file=None, line=None) -> None:
        note = _note_for(message, category)
        if note is not None and (note not in seen or issubclass(category, StartrackWarning)):
            seen.add(note)
            click.echo(f"startrack: warning: {note}", err=True)
    return showwarning


class _AstropyLogOff(importlib.abc.MetaPathFinder):
    """When astropy is imported, undo its redirect of warnings to its own logger (which
    would print ``WARNING: ...`` lines past our hook)."""

    def find_spec(self, name, path=None, target=None):
        if name != "astropy":
            return None
        sys.meta_path.remove(self)  # find the real spec without coming back here
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module) -> None:
            run(module)
            log = getattr(module, "log", None)
            with contextlib.suppress(Exception):  # a future astropy may differ: keep going
                if log.warnings_logging_enabled():
                    log.disable_warnings_logging()
                log.setLevel(logging.ERROR)
        spec.loader.exec_module = exec_module
        return spec


@contextlib.contextmanager
def library_noise_captured():
    """Within: warnings are our one-line notes or dropped, library log records dropped."""
    root = logging.getLogger()
    sink = logging.NullHandler()  # with a handler on the root, logging's stderr fallback
    root.addHandler(sink)         # (lastResort) never prints a library's record
    finder = None
    if "astropy" in sys.modules:
        with contextlib.suppress(Exception):
            sys.modules["astropy"].log.disable_warnings_logging()
    else:
        finder = _AstropyLogOff()
        sys.meta_path.insert(0, finder)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", StartrackWarning)
            warnings.showwarning = _show_warning(set())
            yield
    finally:
        root.removeHandler(sink)
        if finder is not None and finder in sys.meta_path:
            sys.meta_path.remove(finder)

__all__ = ["NOTES", "library_noise_captured"]
