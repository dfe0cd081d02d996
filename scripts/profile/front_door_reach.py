"""How often code reaches past a stage's front door: imports of another stage's private
module, counted in the package, the tests and the scripts of a checkout.

    .venv/bin/python scripts/profile/front_door_reach.py [CHECKOUT] [--list]

A module or folder starting with ``_`` inside a stage folder is private to that stage; a
test in ``tests/<stage>/`` counts as inside that stage; ``startrack._core`` (the compiled
layer every stage calls) counts only from outside the package. The rule the package is
held to is ``tests/package/test_front_doors.py``; this script also counts where no test
holds it (the tests) and works on an old checkout, for before-and-after figures.
"""

from __future__ import annotations

import argparse
import ast
from collections import Counter
from pathlib import Path


def _owner(root: Path, path: Path, stages: set[str]) -> str | None:
    rel = path.relative_to(root).parts
    if rel[0] in ("startrack", "tests") and len(rel) > 2 and rel[1] in stages:
        return rel[1]
    return None


def _imported(node: ast.AST) -> list[str]:
    if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
        return [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    return []


def _reaches(module: str, top: str, own: str | None) -> bool:
    parts = module.split(".")
    if parts[0] != "startrack" or len(parts) < 3:
        return False
    if parts[1] == "_core":
        stage = parts[2] if len(parts) > 3 else "_core"
        return top != "startrack" and stage != own
    private = any(p.startswith("_") and not p.startswith("__") for p in parts[2:])
    return private and parts[1] != own


def reaches(root: Path) -> list[tuple[str, int, str]]:
    """(file, line, module) of every import past another stage's front door."""
    stages = {p.parent.name for p in (root / "startrack").glob("*/__init__.py")}
    found = []
    for top in ("startrack", "tests", "scripts"):
        for path in sorted((root / top).rglob("*.py")):
            own = _owner(root, path, stages)
            for node in ast.walk(ast.parse(path.read_text())):
                hit = next((m for m in _imported(node) if _reaches(m, top, own)), None)
                if hit:
                    found.append((str(path.relative_to(root)), node.lineno, hit))
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkout", nargs="?", type=Path, default=Path("."))
    ap.add_argument("--list", action="store_true", help="print every import counted")
    args = ap.parse_args()
    found = reaches(args.checkout.resolve())
    counts = Counter(f.split("/")[0] for f, _, _ in found)
    print(", ".join(f"{top}: {counts.get(top, 0)}" for top in ("startrack", "tests", "scripts")))
    if args.list:
        for f, line, module in found:
            print(f"  {f}:{line} {module}")


if __name__ == "__main__":
    main()
