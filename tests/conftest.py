"""Shared test set-up: an isolated database cache for the whole session."""

import os

import pytest


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache(tmp_path_factory):
    """Database caches go to a per-session folder, never the user's cache."""
    path = tmp_path_factory.mktemp("startrack-cache")
    old = os.environ.get("STARTRACK_CACHE_DIR")
    os.environ["STARTRACK_CACHE_DIR"] = str(path)
    yield path
    if old is None:
        os.environ.pop("STARTRACK_CACHE_DIR", None)
    else:
        os.environ["STARTRACK_CACHE_DIR"] = old
