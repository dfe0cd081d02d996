"""Shared test set-up: an isolated database cache for the whole session, and the two
star databases the matcher tests share (built once per session)."""

import os

import pytest

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.sky import SkySpec, load_sky, random_sky


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


@pytest.fixture(scope="session")
def random_db(_isolated_cache) -> StarDatabase:
    """A random 2000-star sky seen through a 17.5 deg 1024^2 camera: ~15 stars a frame,
    the 2011 paper's setup, and fast to build."""
    return StarDatabase(random_sky(2000, seed=11), Camera.from_fov(1024, 1024, 17.5))


@pytest.fixture(scope="session")
def hip_db(_isolated_cache) -> StarDatabase:
    """Hipparcos Hp <= 6.5 through a 20 deg 1024^2 camera (~90 stars a frame), with the
    stars the camera cannot split merged, as the CLI loads it."""
    camera = Camera.from_fov(1024, 1024, 20.0)
    return StarDatabase(load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), camera), camera)
