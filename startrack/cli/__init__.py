"""The ``startrack`` command group: simulate, identify, compare, calibrate, cache."""

from __future__ import annotations

import os
import signal
import sys

import click

from startrack import __version__
from startrack.cli._quiet import library_noise_captured
from startrack.defaults import max_pairs
from startrack.errors import InputError
from startrack.io import OutputClosed, cache_max_bytes, max_image_pixels


class Terminated(Exception):
    """SIGTERM arrived: unwind (so temporary files are removed) and exit 143."""


def _on_sigterm(signum, frame) -> None:
    raise Terminated()


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _finish(code: int) -> int:
    """Flush standard output; a full disk is one line and exit 2, a closed pipe quiet."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
        return 2
    except OSError as exc:
        _silence_stdout()
        click.echo(f"startrack: error: standard output: cannot write "
                   f"({exc.strerror or exc})", err=True)
        return 2
    return code


def _check_environment() -> None:
    """Read every numeric environment variable once, before any work: a bad value is one
    line and exit 2 at the start, not a failure halfway (docs/limits.md)."""
    cache_max_bytes()
    max_image_pixels()
    max_pairs()


class StartrackGroup(click.Group):
    """A group that reports every usage or input error as one line and exit code 2."""

    def main(self, args=None, prog_name=None, **extra):
        try:
            previous = signal.signal(signal.SIGTERM, _on_sigterm)
        except ValueError:  # not the main thread (an embedding caller): leave signals be
            previous = None
        try:
            with library_noise_captured():
                code = _finish(self._run(args, prog_name, **extra))
        finally:
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
        sys.exit(code)

    def _run(self, args, prog_name, **extra) -> int:
        try:
            _check_environment()
            super().main(args=args, prog_name=prog_name or "startrack",
                         standalone_mode=False, **extra)
            return 0
        except SystemExit as exc:
            if isinstance(sys.stdout, getattr(click.utils, "_PacifyFlushWrapper", ())):
                _silence_stdout()  # click met a closed pipe (EPIPE) and went quiet
                return 2
            return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except click.exceptions.Exit as exc:
            return exc.exit_code
        except click.exceptions.Abort:
            click.echo("startrack: aborted", err=True)
            return 130
        except Terminated:
            click.echo("startrack: terminated (SIGTERM); nothing half-written was left",
                       err=True)
            return 143
        except OutputClosed:
            _silence_stdout()
            return 2
        except click.UsageError as exc:
            where = f" ({exc.ctx.command_path})" if exc.ctx is not None else ""
            click.echo(f"startrack: error{where}: {exc.format_message()}", err=True)
            return 2
        except click.ClickException as exc:
            click.echo(f"startrack: error: {exc.format_message()}", err=True)
            return 2
        except InputError as exc:
            click.echo(f"startrack: error: {exc}", err=True)
            return 2
        except BrokenPipeError:
            _silence_stdout()
            return 2
        except OSError as exc:  # I/O failing outside an output's own handling: stdout
            _silence_stdout()
            where = exc.filename or "standard output"
            click.echo(f"startrack: error: {where}: cannot write ({exc.strerror or exc})",
                       err=True)
            return 2
        except MemoryError:
            click.echo("startrack: error: out of memory (see the size limits in "
                       "docs/limits.md)", err=True)
            return 2


@click.group(cls=StartrackGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="startrack")
def main() -> None:
    """Star-tracker simulator and star-identification bench. Conventions (pixels,
    attitude, file formats, exit codes): docs/conventions.md."""


def _add_commands() -> None:
    # Each command lives in its own module; importing it registers it on the group.
    from startrack.cli import (  # noqa: F401
        _cache,
        _calibrate,
        _compare,
        _identify,
        _simulate,
    )


_add_commands()

__all__ = ["StartrackGroup", "Terminated", "main"]
