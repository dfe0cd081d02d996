"""Every module, file and name the code and docs refer to exists: a dotted name such as
``startrack.solver._fov_given.keep_given``, a path such as ``scripts/bench/bench_identify.py``, a
compiled source named by its file (``verification.pxd``), or a module of the same folder
named in a docstring or comment (``_fov_given.keep_given``). A move that leaves a stale
reference behind fails here."""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest
from repo_paths import ROOT

PACKAGE = ROOT / "startrack"
SOURCES = ("*.py", "*.pyx", "*.pxd", "*.pxi")
DOTTED = re.compile(r"(?<![\w/.])startrack(?:\.\w+)+")
PATH = re.compile(r"(?<![\w./-])((?:startrack|scripts|tests|docs|configs|data|examples)"
                  r"/[\w./-]*\w\.(?:py|pyx|pxd|pxi|md|toml|csv|json))\b")
COMPILED_FILE = re.compile(r"(?<![\w/.])(\w+\.(?:pyx|pxd|pxi))\b")
SIBLING = re.compile(r"(?<![\w.])(_[a-z][a-z0-9_]*)\.([A-Za-z_]\w*)")
DEFINED = re.compile(r"^\s*(?:(?:cdef|cpdef|ctypedef)\s+(?:class\s+|struct\s+|enum\s+|inline\s+|"
                     r"public\s+|readonly\s+)*(?:[\w\[\]*,\s]+\s+)?|def\s+|class\s+|async\s+def\s+)?"
                     r"\*?(\w+)\s*(?:[=:(\[]|$)", re.M)


def _files(*globs) -> list[Path]:
    roots = [PACKAGE, ROOT / "scripts", ROOT / "tests"]
    found = [p for r in roots for g in globs for p in r.rglob(g)
             if "data" not in p.parts and p.resolve() != Path(__file__).resolve()]
    return sorted(set(found))


def _module_file(parts: list[str]) -> Path | None:
    base = ROOT.joinpath(*parts)
    for candidate in (base / "__init__.py", *(base.with_suffix(s) for s in (".py", ".pyx",
    ".pxd"))):
        if candidate.is_file():
            return candidate
    return None


def _names(path: Path) -> set[str]:
    text = path.read_text()
    if path.suffix in (".pyx", ".pxd"):  # a compiled module holds what it includes
        text += "".join(p.read_text() for p in path.parent.glob("*.pxi"))
    names = set(DEFINED.findall(text)) | set(re.findall(r"\b(\w+)\s*=", text))
    if path.name == "__init__.py":  # a package's lazy re-exports and __all__
        names |= set(re.findall(r'"(\w+)"', text))
    imported = re.findall(r"import\s+\(([^)]*)\)", text) + re.findall(r"import ([^\n(]+)", text)
    names |= set(re.findall(r"\b(\w+)\b", " ".join(imported)))
    return names


def stale_dotted(text: str) -> list[str]:
    """Dotted names whose module does not exist, or does not define the name after it."""
    stale = []
    for ref in set(DOTTED.findall(text)):
        parts = ref.split(".")
        k = len(parts)
        while k > 1 and _module_file(parts[:k]) is None:
            k -= 1
        module = _module_file(parts[:k])
        rest = parts[k] if k < len(parts) else None
        if module is None or (rest is not None and not rest.startswith("__")
                              and rest not in _names(module)):
            stale.append(ref)
    return sorted(stale)


def stale_paths(text: str) -> list[str]:
    return sorted({p for p in PATH.findall(text) if not (ROOT / p).exists()
                   and len(Path(p).stem) > 1})  # x.py: an example's placeholder


def _prose(path: Path) -> str:
    """A source file's docstrings and comments (where a reader follows a reference)."""
    text = path.read_text()
    if path.suffix != ".py":
        return "\n".join(re.findall(r"#.*|\"\"\"[\s\S]*?\"\"\"", text))
    kept = []
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT or (tok.type == tokenize.STRING
                                            and tok.string.startswith(('"""', 'r"""'))):
            kept.append(tok.string)
    return "\n".join(kept)


def stale_siblings(path: Path) -> list[str]:
    """``_module.name`` in prose: a module of the folder (or the compiled core's) that
    does not exist, or lacks the name."""
    compiled = {p.stem for p in (PACKAGE / "_core").rglob("*.p*")}
    here = {p.stem: p for p in path.parent.glob("*.py*")}
    everywhere = {p.stem for p in PACKAGE.rglob("_*.py*")} | compiled
    stale = []
    for module, name in set(SIBLING.findall(_prose(path))):
        if name in ("py", "pyx", "pxd", "pxi") or module in {d.name for d in PACKAGE.rglob("_*")
                                                              if d.is_dir()}:
            continue  # a file's name (checked as a path), or a folder's
        if module in here:
            if name not in _names(here[module]):
                stale.append(f"{module}.{name}")
        elif module not in everywhere and module.lstrip("_") not in {
                p.stem for p in PACKAGE.rglob("*.py*")}:
            stale.append(f"{module}.{name}")
    return sorted(stale)


#: this file, whose test feeds the checks stale references on purpose
SELF = Path(__file__).resolve()


def _docs() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("path", _files(*SOURCES) + _docs(), ids=lambda p: str(p.relative_to(ROOT)))
def test_dotted_names_and_paths_exist(path):
    text = path.read_text()
    assert stale_dotted(text) == []
    assert stale_paths(text) == []


@pytest.mark.parametrize("path", _files(*SOURCES), ids=lambda p: str(p.relative_to(ROOT)))
def test_compiled_files_and_sibling_modules_named_exist(path):
    compiled = {p.name for p in (PACKAGE / "_core").rglob("*.p*")}
    named = set(COMPILED_FILE.findall(_prose(path)))
    assert sorted(named - compiled) == []
    assert stale_siblings(path) == []


def test_a_stale_reference_is_found():
    assert stale_dotted("see startrack.solver._fov_fit.keep_given") == [
        "startrack.solver._fov_fit.keep_given"]
    assert stale_dotted("see startrack.solver._fov_given.keep_given") == []
    moved = "startrack.matching.verify_kernels"
    assert stale_dotted(moved) == [moved]
    assert stale_paths("run scripts/bench_identify.py") == ["scripts/bench_identify.py"]
    assert stale_paths("run scripts/bench/bench_identify.py") == []
