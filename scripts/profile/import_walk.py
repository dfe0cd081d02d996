"""The files and folders of startrack that one command passes through: every startrack
module it imports (Python and compiled), and the folders that hold them.

    .venv/bin/python scripts/profile/import_walk.py -- identify frame.png --fov 11.42

Runs the command in this process (its exit code is ignored) and prints the counts, then
``--list`` the modules. A walk a reader follows crosses these files; fewer is easier.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path


def walk(command: list[str]) -> list[Path]:
    """The startrack source files loaded while ``startrack <command>`` runs."""
    from startrack.cli import main  # the command group, as the installed script runs it

    with contextlib.suppress(SystemExit), contextlib.redirect_stdout(io.StringIO()):
        main(args=command, prog_name="startrack")
    files = {Path(m.__file__) for name, m in list(sys.modules.items())
             if name.startswith("startrack") and getattr(m, "__file__", None)}
    return sorted(files)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--list", action="store_true", help="print every module")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="the startrack command")
    args = ap.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    files = walk(command)
    root = Path(__import__("startrack").__file__).parent
    folders = {f.parent.relative_to(root.parent) for f in files}
    modules = [f for f in files if f.suffix == ".py" and f.name != "__init__.py"]
    doors = [f for f in files if f.name == "__init__.py"]
    print(f"startrack {' '.join(command)}: {len(files)} files in {len(folders)} folders: "
          f"{len(modules)} Python modules, {len(doors)} __init__, "
          f"{len(files) - len(modules) - len(doors)} compiled")
    if args.list:
        for f in files:
            print(f"  {f.relative_to(root.parent)}")


if __name__ == "__main__":
    main()
