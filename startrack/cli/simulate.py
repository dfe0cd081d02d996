"""`startrack simulate`: render CCD frames of a sky with the truth beside each frame."""

from __future__ import annotations

import click

from startrack.cli import main


@main.command()
def simulate() -> None:
    """Render frames (being built)."""
    raise click.ClickException("simulate is not built yet")
