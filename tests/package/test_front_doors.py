"""Each stage is entered by its front door: a module whose name (or a folder above it inside
the stage) starts with ``_`` is private to its stage, so another stage imports the names the
stage's ``__init__`` lists, never the module. The three former halls stay divided into rooms."""

from __future__ import annotations

import ast
from pathlib import Path

from repo_paths import ROOT

PACKAGE = ROOT / "startrack"
STAGES = sorted(p.parent.name for p in PACKAGE.glob("*/__init__.py") if p.parent.name != "_core")

#: Scripts that measure a stage from inside, and why each must.
SCRIPTS_INSIDE = {
    "scripts/profile/_kernel_clock.py": "wraps the compiled entry points where each stage calls "
                                        "them, to clock the time spent inside the core",
    "scripts/profile/profile_tracking.py": "times each internal step of a tracked frame",
    "scripts/bench/bench_tracking.py": "times the tracking bench's sequences step by step",
    "scripts/bench/bench_database.py": "times the compiled database builds without the cache",
    "scripts/bench/bench_blind_tables.py": "builds each quad table level alone, uncached",
    "scripts/bench/bench_centroid_sky.py": "times the centroider's sky model alone",
    "scripts/bench/bench_blind_diagnose.py": "runs the blind search's windows one by one",
}


def _stage_of(path: Path) -> str | None:
    rel = path.relative_to(PACKAGE).parts
    return rel[0] if len(rel) > 1 and rel[0] in STAGES else None


def private_reaches(path: Path, own: str | None) -> list[str]:
    """The modules ``path`` imports that are private to a stage other than ``own``
    (``startrack._core``, the compiled layer every stage calls, aside)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if (len(parts) > 2 and parts[0] == "startrack" and parts[1] in STAGES
                    and parts[1] != own
                    and any(p.startswith("_") and not p.startswith("__") for p in parts[2:])):
                found.append(f"{path.name}:{node.lineno} {name}")
                break
    return found


def test_no_stage_imports_another_stages_private_module():
    reaches = [r for p in sorted(PACKAGE.rglob("*.py")) for r in private_reaches(p, _stage_of(p))]
    assert reaches == []


def test_scripts_reach_inside_a_stage_only_where_listed():
    reaching = {str(p.relative_to(ROOT)) for p in (ROOT / "scripts").rglob("*.py")
                if private_reaches(p, None)}
    assert sorted(reaching - set(SCRIPTS_INSIDE)) == []
    assert len(SCRIPTS_INSIDE) <= 15


def test_a_private_reach_is_found(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("from startrack.solver._fov_fit import fit_focal\n"
                     "from startrack.solver import Pipeline\n")
    assert len(private_reaches(probe, "camera")) == 1
    assert private_reaches(probe, "solver") == []


def test_one_prefix_rule_in_every_stage():
    """Every module of a stage folder is private (``_``) itself or below a private folder:
    the ``__init__`` is the stage's only public module."""
    public = [str(p.relative_to(PACKAGE)) for stage in STAGES
              for p in (PACKAGE / stage).rglob("*.py") if p.name != "__init__.py"
              and not any(part.startswith("_") for part in p.relative_to(PACKAGE / stage).parts)]
    assert public == []


def test_the_halls_are_divided_into_rooms():
    def top_files(folder: Path, suffixes: tuple[str, ...]) -> list[str]:
        return [p.name for p in folder.iterdir() if p.is_file() and p.suffix in suffixes]

    assert len(top_files(ROOT / "tests", (".py",))) <= 15
    assert len(top_files(ROOT / "scripts", (".py",))) <= 12
    assert len(top_files(PACKAGE / "_core", (".py", ".pyx", ".pxd", ".pxi"))) <= 25
