"""The shape of the package: no import cycles between its parts, short files and functions,
no matcher importing a sibling, stage types outside the plugin package."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "startrack"
MAX_FILE_LINES = 300
MAX_FUNCTION_LINES = 60


def _modules() -> dict[str, Path]:
    mods = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        mods[".".join(parts)] = path
    return mods


def _imports(path: Path) -> set[str]:
    """Every startrack module ``path`` imports, at any depth (lazy imports count too)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m for m in found if m.split(".")[0] == "startrack"}


def _part(module: str) -> str:
    """The package part a module belongs to: its subpackage, or the module itself."""
    parts = module.split(".")
    return ".".join(parts[:2])


def _part_graph() -> dict[str, set[str]]:
    mods = _modules()
    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        src = _part(name)
        for target in _imports(path):
            while target not in mods and "." in target:
                target = target.rsplit(".", 1)[0]
            dst = _part(target)
            if target in mods and dst != src and dst != "startrack":
                graph.setdefault(src, set()).add(dst)
    return graph


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_no_import_cycle_between_package_parts():
    assert _find_cycle(_part_graph()) is None


def test_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}}) is None


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.name)
def test_files_and_functions_are_short(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MAX_FILE_LINES
    long = [f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(ast.parse(text))
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert long == []
    assert text.lstrip().startswith('"""'), "a module's first line says what it is for"


def test_no_matcher_imports_a_sibling_matcher():
    mods = _modules()
    plugins = {m for m in mods if m.startswith("startrack.matchers.")
               and not m.rsplit(".", 1)[1].startswith("_") and m != "startrack.matchers.base"}
    for name in plugins:
        siblings = {t for t in _imports(mods[name]) if any(t.startswith(p) for p in plugins)}
        assert siblings <= {name}, f"{name} imports {siblings - {name}}"


def test_stage_code_does_not_import_the_plugin_package_for_types():
    """Stage types live in startrack.types; identify may know the Matcher interface."""
    allowed = {"verify/_verification": set(), "outputs/_records": set(),
               "solver/_lost_in_space": {"startrack.matchers.base"}}
    for name, ok in allowed.items():
        imported = {m for m in _imports(PACKAGE / f"{name}.py")
                    if m.startswith("startrack.matchers")}
        assert {m for m in imported if not any(m.startswith(a) for a in ok)} == set(), name
