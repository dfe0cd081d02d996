"""`startrack cache info|clear`: where the on-disk cache is, how big, and emptying it."""

from __future__ import annotations

import click

from startrack.cli import main
from startrack.cli._shared_options import notes, verbosity
from startrack.io import DEFAULT_CACHE_MAX_MB


def _mb(n: int) -> str:
    return f"{n / (1024 * 1024):.1f} MB"


@main.group(help=f"""The on-disk cache of catalogs and star databases (rebuilt when missing).

    Its folder is $STARTRACK_CACHE_DIR, else the user cache folder; its size is capped at
    $STARTRACK_CACHE_MAX_MB megabytes (default {DEFAULT_CACHE_MAX_MB}), least recently used
    entries first out.""")
def cache() -> None:
    """``startrack cache``: its help text reads the cap from the code (DEFAULT_CACHE_MAX_MB)."""


@cache.command()
@verbosity
def info(quiet, verbose) -> None:
    """Print the cache folder, its entries, total size and cap (-v: every entry on
    stderr)."""
    from startrack.io import cache_dir, cache_entries, cache_max_bytes

    entries = cache_entries()
    total = sum(size for _, size, _ in entries)
    click.echo(f"folder:  {cache_dir()}")
    click.echo(f"entries: {len(entries)}")
    click.echo(f"size:    {_mb(total)} (cap {_mb(cache_max_bytes())}, STARTRACK_CACHE_MAX_MB)")
    kinds: dict[str, list[int]] = {}
    detail = notes(quiet, verbose)[1]
    for path, size, _ in entries:
        detail(f"  {path.name}  {_mb(size)}")
        count_size = kinds.setdefault(path.name.split("-", 1)[0], [0, 0])
        count_size[0] += 1
        count_size[1] += size
    for kind, (count, size) in sorted(kinds.items()):
        click.echo(f"  {kind:<16} {count:>4} entr{'y' if count == 1 else 'ies'}  {_mb(size)}")


@cache.command()
@verbosity
def clear(quiet, verbose) -> None:
    """Remove every cache entry (they are rebuilt when next needed). -q and -v are
    accepted as on every command; clear prints only its result, on stdout."""
    from startrack.io import cache_dir, clear_cache

    count, freed = clear_cache()
    click.echo(f"removed {count} entr{'y' if count == 1 else 'ies'} ({_mb(freed)}) "
               f"from {cache_dir()}")

__all__ = ["cache", "clear", "info"]
