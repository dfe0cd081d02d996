"""Matchers from other packages: the ``startrack.matchers`` entry point group loads them
into --method/--methods and compare; the example package's matcher works."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner
from repo_paths import ROOT
from synth import assert_correct, frames

import startrack.matchers as matchers
from startrack.cli import main
from startrack.matchers import _base as base
from startrack.solver import identify

EXAMPLE = ROOT / "examples" / "startrack-plugin-example"


def _fake_distribution(root: Path, name: str, module: str, source: str,
                       entry: str) -> None:
    """An installed distribution as importlib.metadata finds it on sys.path: a module and
    a ``*.dist-info`` folder with METADATA and entry_points.txt."""
    (root / f"{module}.py").write_text(textwrap.dedent(source))
    info = root / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[startrack.matchers]\n{entry}\n")


@pytest.fixture
def fresh_registry(monkeypatch):
    """Matchers reloaded from scratch (and the registry restored afterwards)."""
    monkeypatch.setattr(base, "_REGISTRY", dict(base._REGISTRY))
    monkeypatch.setattr(matchers, "_loaded", False)


PLUGIN = """
    import itertools
    from startrack.matchers import Matcher, get_matcher

    class FirstTwo(Matcher):
        name = "fake_first_two"

        def __init__(self, database, config=None):
            super().__init__(database, config)
            self.inner = get_matcher("pyramid")(database, config)

        def prepare(self):
            self.inner.prepare()

        def hypotheses(self, obs, diag, screen_rad=None):
            return itertools.islice(self.inner.hypotheses(obs, diag, screen_rad), 2)
"""


def test_entry_point_matcher_runs_in_compare_beside_pyramid(tmp_path, monkeypatch,
                                                            fresh_registry):
    _fake_distribution(tmp_path, "fake_plugin", "fake_plugin_mod", PLUGIN,
                       "fake_first_two = fake_plugin_mod:FirstTwo")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "fake_first_two" in matchers.available_methods()
    out = tmp_path / "cmp"
    result = CliRunner().invoke(main, ["compare", "--methods", "pyramid,fake_first_two",
                                       "--frames", "6", "--noise-px", "0.3",
                                       "--false-stars", "0", "--jobs", "1", "-q",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    import pandas as pd

    summary = pd.read_csv(out / "summary.csv")
    assert sorted(summary["method"]) == ["fake_first_two", "pyramid"]
    ours = summary.set_index("method")
    assert ours.loc["fake_first_two", "wrong_rate"] == 0
    assert ours.loc["fake_first_two", "correct_rate"] > 0.5


def test_a_broken_or_foreign_plugin_is_a_warning_not_a_crash(tmp_path, monkeypatch,
                                                             fresh_registry):
    _fake_distribution(tmp_path, "broken_plugin", "broken_mod", "raise ImportError('nope')\n",
                       "broken = broken_mod:Thing")
    _fake_distribution(tmp_path, "foreign_plugin", "foreign_mod", "class Thing: pass\n",
                       "foreign = foreign_mod:Thing")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.warns(UserWarning) as caught:
        names = matchers.available_methods()
    text = " ".join(str(w.message) for w in caught)
    assert "'broken'" in text and "nope" in text
    assert "'foreign'" in text and "not a startrack Matcher" in text
    assert "pyramid" in names and "broken" not in names


def test_example_package_matcher_identifies_frames(random_db, monkeypatch, fresh_registry):
    monkeypatch.syspath_prepend(str(EXAMPLE / "src"))
    from startrack_plugin_example import BudgetPyramidMatcher

    matcher = BudgetPyramidMatcher(random_db, budget=3)
    matcher.prepare()
    found = list(frames(random_db.catalog, random_db.camera, 6, seed=21))
    assert found
    for frame in found:
        solution = identify(frame.obs, matcher)
        assert_correct(solution, frame.truth_rows)
        assert solution.method == "pyramid_budget"
    # a budget of 0 hypotheses solves nothing (verification never sees one)
    none = BudgetPyramidMatcher(random_db, budget=0)
    assert not identify(found[0].obs, none).solved


def test_example_package_declares_its_entry_point():
    import tomllib

    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    entry = project["entry-points"][matchers.ENTRY_POINT_GROUP]
    assert entry == {"pyramid_budget": "startrack_plugin_example:BudgetPyramidMatcher"}
