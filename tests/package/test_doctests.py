"""The public API's documentation holds: each of startrack.solve, Solver, SolveResult, Camera,
load_sky, extract_centroids, Matcher and register has numpydoc sections, and its Examples run
as written (docs/api.md lists them)."""

from __future__ import annotations

import importlib
import json
import re

import pytest
from repo_paths import ROOT
from waiting import run_python

API_DOC = ROOT / "docs" / "api.md"

# (module, name) of each documented object; the sections its docstring must hold
PUBLIC = {
    ("startrack.api", "solve"): ("Parameters", "Returns", "Raises", "Examples"),
    ("startrack.api", "Solver"): ("Parameters", "Raises", "Examples"),
    ("startrack.api", "Solver.solve"): ("Parameters", "Returns", "Raises"),
    ("startrack.api._result", "SolveResult"): ("Parameters", "Attributes", "Raises", "Examples"),
    ("startrack.camera._model", "Camera"): ("Parameters", "Raises", "Examples"),
    ("startrack.sky", "load_sky"): ("Parameters", "Returns", "Raises", "Examples"),
    ("startrack.centroids._extract", "extract_centroids"):
        ("Parameters", "Returns", "Raises", "Examples"),
    ("startrack.matchers._base", "Matcher"): ("Parameters", "Raises", "Examples"),
    ("startrack.matchers._base", "register"): ("Parameters", "Returns", "Raises", "Examples"),
}

# Run in a new interpreter: the examples register matchers, which must not leak into the
# registry the other tests see. Prints {name: [failed, attempted, report]}.
CHILD = """
import doctest, importlib, io, json, sys
answers = {}
for module_name, name in json.loads(sys.argv[1]):
    obj = importlib.import_module(module_name)
    for part in name.split("."):
        obj = getattr(obj, part)
    finder = doctest.DocTestFinder(recurse=False)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    out = io.StringIO()
    for test in finder.find(obj, name, globs={}):
        runner.run(test, out=out.write)
    result = runner.summarize(verbose=False)
    answers[name] = [result.failed, result.attempted, out.getvalue()]
print(json.dumps(answers))
"""


@pytest.fixture(scope="module")
def doctest_results() -> dict:
    with_examples = [key for key, sections in PUBLIC.items() if "Examples" in sections]
    return json.loads(run_python(CHILD, json.dumps(with_examples)).splitlines()[-1])


def _docstring(module_name: str, name: str) -> str:
    obj = __import__(module_name, fromlist=["_"])
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj.__doc__ or ""


@pytest.mark.parametrize(("module_name", "name"), sorted(PUBLIC), ids=lambda v: str(v))
def test_public_docstring_has_numpydoc_sections(module_name, name):
    doc = _docstring(module_name, name)
    underlined = set(re.findall(r"^\s*(\w+)\n\s*-{3,}$", doc, flags=re.MULTILINE))
    assert set(PUBLIC[module_name, name]) <= underlined


@pytest.mark.parametrize(("module_name", "name"),
                         sorted(k for k, s in PUBLIC.items() if "Examples" in s),
                         ids=lambda v: str(v))
def test_public_examples_run(doctest_results, module_name, name):
    failed, attempted, report = doctest_results[name]
    assert attempted >= 3, f"{name}: its Examples hold {attempted} statements"
    assert failed == 0, report


def test_a_wrong_example_fails():
    """The runner can fail: an example whose printed answer is wrong is counted."""
    import doctest

    def wrong():
        """
        >>> 1 + 1
        3
        """

    runner = doctest.DocTestRunner()
    for test in doctest.DocTestFinder().find(wrong, "wrong", globs={}):
        runner.run(test, out=lambda _: None)
    assert runner.summarize(verbose=False).failed == 1


STAGES = ["startrack", "startrack.camera", "startrack.sky", "startrack.simulate", "startrack.io",
          "startrack.centroids", "startrack.database", "startrack.matchers", "startrack.verify",
          "startrack.solver", "startrack.tracking", "startrack.outputs"]


@pytest.mark.parametrize("package", STAGES)
def test_docs_api_lists_every_public_name(package):
    listed = set(re.findall(r"^\| `(\w+)` \|", API_DOC.read_text(), flags=re.MULTILINE))
    exported = set(importlib.import_module(package).__all__) - {"__version__"}
    assert sorted(exported - listed) == []
