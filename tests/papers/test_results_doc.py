"""docs/results.md is built from every paper's saved tables (docs/data/<section>/), each
stamped with the command, commit and date that made it; re-rendering cannot drop one."""

import json

import pandas as pd
import pytest
from repo_paths import ROOT

from scripts.papers import _results_doc  # noqa: E402


@pytest.mark.parametrize("section", _results_doc.SECTIONS, ids=lambda s: s.slug)
def test_every_section_is_saved_stamped_and_shown(section):
    assert _results_doc.unstamped(section.folder) is None
    run = _results_doc.load_run(section.folder)
    text = _results_doc.DOC.read_text()
    assert f"## {section.title}\n" in text, "the page lacks the section"
    assert run["command"] in text and run["git commit"][:12] in text, "shown unstamped"


def test_sections_are_named_after_the_papers_not_numbered():
    for section in _results_doc.SECTIONS:
        assert "seed" not in section.title.lower() and "seed" not in section.slug
    text = _results_doc.DOC.read_text()
    assert "seed 000" not in text.lower() and "seed 002" not in text.lower()


def test_a_section_without_its_record_or_tables_is_unstamped(tmp_path):
    assert "no run.json" in _results_doc.unstamped(tmp_path)
    record = {"command": "x", "git commit": "abc", "date (UTC)": "d", "CPU": "c"}
    _results_doc.save_tables(tmp_path, record, {"table": pd.DataFrame({"a": [1]})})
    assert _results_doc.unstamped(tmp_path) is None
    (tmp_path / "table.csv").unlink()
    assert "lacks the tables table" in _results_doc.unstamped(tmp_path)
    _results_doc.save_tables(tmp_path, {**record, "command": ""}, {})
    assert "lacks command" in _results_doc.unstamped(tmp_path)
    assert json.loads((tmp_path / "run.json").read_text())["tables"] == []


def test_render_keeps_a_section_whose_tables_are_missing(tmp_path, monkeypatch):
    """A section not run renders as a note under its title; the others stay."""
    missing = _results_doc.Section("nowhere", "A paper never run", "scripts/x.py",
                                   "scripts.papers._doc_triangle_base")
    monkeypatch.setattr(_results_doc, "DATA", tmp_path)
    monkeypatch.setattr(_results_doc, "SECTIONS", (missing,))
    doc = _results_doc.render(tmp_path / "results.md")
    text = doc.read_text()
    assert "## A paper never run\n" in text and "not run yet" in text
    assert _results_doc.main(["--check"]) == 1


def test_readme_says_what_the_page_shows():
    """The README's lines on the papers are the ones scripts/docs/readme_results.py writes
    from the saved tables now (re-run it after a paper's script)."""
    from scripts.docs import readme_results

    text = (ROOT / "README.md").read_text()
    assert readme_results.papers_section() in text


def test_the_stamp_says_when_a_run_is_not_full_size():
    full = _results_doc.size_note(".venv/bin/python scripts/papers/radial_features.py --jobs 2")
    assert full == "This is the full-size run.\n"
    small = _results_doc.size_note(".venv/bin/python scripts/papers/radial_features.py --jobs 2 "
                                   "--frames 80 --raw-frames 40 --label-frames 25")
    assert small.startswith("**This is not the full-size run**")
    assert "`--frames 80` (full size 1000)" in small and "make results" in small
