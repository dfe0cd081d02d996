"""The ``startrack`` command group: simulate, identify, compare."""

from __future__ import annotations

import sys

import click

from startrack import __version__
from startrack.errors import InputError


class StartrackGroup(click.Group):
    """A group that reports every usage or input error as one line and exit code 2."""

    def main(self, args=None, prog_name=None, **extra):
        try:
            return super().main(args=args, prog_name=prog_name or "startrack",
                                standalone_mode=False, **extra)
        except click.exceptions.Exit as exc:
            sys.exit(exc.exit_code)
        except click.exceptions.Abort:
            click.echo("startrack: aborted", err=True)
            sys.exit(130)
        except click.UsageError as exc:
            where = f" ({exc.ctx.command_path})" if exc.ctx is not None else ""
            click.echo(f"startrack: error{where}: {exc.format_message()}", err=True)
            sys.exit(2)
        except click.ClickException as exc:
            click.echo(f"startrack: error: {exc.format_message()}", err=True)
            sys.exit(2)
        except InputError as exc:
            click.echo(f"startrack: error: {exc}", err=True)
            sys.exit(2)


@click.group(cls=StartrackGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="startrack")
def main() -> None:
    """Star-tracker simulator and star-identification bench. Conventions (pixels,
    attitude, file formats, exit codes): docs/conventions.md."""


def _add_commands() -> None:
    # Each command lives in its own module; importing it registers it on the group.
    from startrack.cli import (
        compare,  # noqa: F401
        identify,  # noqa: F401
        simulate,  # noqa: F401
    )


_add_commands()
