"""Every sentence and number docs/results.md quotes from the two papers, checked against
the papers' stored text (tests/data/papers/, see its README): English and Chinese
sentences character for character (line breaks aside, marked restorations undone),
the reassembled Persian ones word by word, and every number typed from the papers."""

import re
import unicodedata

import pandas as pd
import pytest
from repo_paths import ROOT

from scripts.papers import (
    _doc_papers,  # noqa: E402
    _radial_claims,  # noqa: E402
    _radial_tables,  # noqa: E402
)
from scripts.papers import _paper2011_claims as claims2011  # noqa: E402

PAPERS = ROOT / "tests" / "data" / "papers"
TEXT_2011 = (PAPERS / "triangle_base_2011.txt").read_text(encoding="utf-8")
TEXT_RADIAL = (PAPERS / "radial_features.txt").read_text(encoding="utf-8")


def _squeezed(text: str) -> str:
    return "".join(text.split())


def _ascii_digits(text: str) -> str:
    """Full-width digits, letters and points as ASCII (the Chinese text types numbers in
    full-width characters)."""
    return unicodedata.normalize("NFKC", text)


@pytest.mark.parametrize("claim", [c for c in claims2011.CLAIMS if not c.english],
                         ids=lambda c: c.key)
def test_english_abstract_quotes_are_the_text(claim):
    assert " ".join(claim.original.split()) in " ".join(TEXT_2011.split())


@pytest.mark.parametrize("claim", [c for c in claims2011.CLAIMS if c.english],
                         ids=lambda c: c.key)
def test_persian_quotes_are_the_texts_words(claim):
    """Reassembled quotes (the page marks them): each word is in the text, or is one of
    the words the text splits, whose fragment is in the text."""
    for word in re.split(r"\s+", claim.original):
        word = word.strip(".،")
        if not word:
            continue
        assert "\u200c" not in word, "no zero-width joiner: the text has none"
        fragment = claims2011.REASSEMBLED_WORDS.get(word, word)
        assert fragment in TEXT_2011, word


def test_a_changed_persian_word_would_fail():
    assert "معمولاً" not in TEXT_2011 and "معمولأ" in TEXT_2011


@pytest.mark.parametrize("claim", _radial_claims.CLAIMS, ids=lambda c: c.short)
def test_chinese_quotes_are_the_text_character_for_character(claim):
    quote = claim.original
    for restored, stored in _radial_claims.RESTORED.items():
        quote = quote.replace(restored, stored)
    assert _squeezed(quote) in _squeezed(TEXT_RADIAL)


def test_the_typed_table_rows_are_the_papers_numbers():
    typed = pd.read_csv(_radial_tables.PAPER_ROWS_CSV, dtype=str)
    text = _ascii_digits(TEXT_RADIAL)
    for column in ("x", "y", "lon", "lat"):
        for value in typed[column]:
            assert value in text, (column, value)


def _radial_prose() -> str:
    return _doc_papers.CLAIMS.split("### Radial features")[1]


def test_every_number_the_page_quotes_from_the_radial_paper_is_in_it():
    text = _ascii_digits(TEXT_RADIAL)
    numbers = re.findall(r"\d+\.\d+", _radial_prose())
    assert len(numbers) >= 10
    for number in numbers:
        assert number in text, number
    assert "4096" in text and "9μm" in text.replace(" ", "")


def test_the_rendered_paper_tables_print_the_numbers_as_typed():
    """The section on the paper's Tables 2 to 4 prints each of its sky positions with the
    digits the paper typed (no rounding on the way through the saved tables)."""
    page = (ROOT / "docs" / "results.md").read_text()
    part = page.split("### The paper's Tables 2 to 4")[1].split("###")[0]
    text = _ascii_digits(TEXT_RADIAL)
    quoted = re.findall(r"\((\d+\.\d{4}), (\d+\.\d{4})\)", part)
    assert quoted
    for lon, lat in quoted:
        assert lon in text and lat in text, (lon, lat)


def test_the_2011_setup_numbers_are_in_the_text():
    # the Persian line reads "( 025/0 *025/0)" (right-to-left digits) and "2000 ستاره"
    assert "025/0 *025/0" in TEXT_2011 and "2000" in TEXT_2011
    assert "0.025 x 0.025" in _doc_papers.CLAIMS and "2000" in _doc_papers.CLAIMS
