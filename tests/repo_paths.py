"""Where the tests find the checkout's files, from any folder of tests/."""

from pathlib import Path

TESTS = Path(__file__).resolve().parent
#: the checkout's root (pyproject.toml, startrack/, scripts/, docs/)
ROOT = TESTS.parent
#: the frames, catalogs and papers the tests read (tests/data/)
DATA = TESTS / "data"
