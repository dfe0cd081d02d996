"""The matchers' constructor keywords: the shared ones go to their base class, the defaults
stay as documented, and a peer's solve settings reach the peer under its own names."""

from __future__ import annotations

import pytest

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.matchers import get_matcher
from startrack.matchers._base import MatcherConfig
from startrack.matchers._shared.peer import PEER_DB_DEFAULTS
from startrack.sky import load_sky


@pytest.fixture(scope="module")
def database():
    camera = Camera.from_fov(640, 480, 15.0)
    return StarDatabase(load_sky("random", camera), camera)


@pytest.mark.parametrize("name", ["angle", "hybrid", "pyramid"])
def test_pattern_pair_keywords(database, name):
    cls = get_matcher(name)
    default = cls(database, MatcherConfig(extra_stars=7))
    assert (default.pattern_per_region, default.region_radius_deg, default.extra_stars) \
        == (15, None, 7)
    given = cls(database, pattern_per_region=None, region_radius_deg=3.0, extra_stars=0)
    assert (given.pattern_per_region, given.region_radius_deg, given.extra_stars) \
        == (None, 3.0, 0)
    assert given._tables()[0] is database.pairs  # None: every catalog pair
    with pytest.raises(TypeError, match="no_such_setting"):
        cls(database, no_such_setting=1)


def test_tetra3_solve_keywords(database):
    matcher = get_matcher("tetra3")(database, solve_timeout_ms=500, match_radius=0.02,
                                    patterns_per_lattice_field=20)
    assert matcher.solve_kwargs == {"fov_max_error": 0.5, "match_radius": 0.02,
                                    "match_threshold": 1e-4, "solve_timeout": 500.0}
    assert matcher.db_params == {**PEER_DB_DEFAULTS, "patterns_per_lattice_field": 20}


def test_tetra3rs_solve_keywords(database):
    matcher = get_matcher("tetra3rs")(database, hypothesis_stars=5)
    assert matcher.solve_kwargs == {"fov_max_error_deg": 0.5, "match_radius": 0.01,
                                    "match_threshold": 1e-5, "solve_timeout_ms": 5000}
    assert isinstance(matcher.solve_kwargs["solve_timeout_ms"], int)
    assert (matcher.hypothesis_stars, matcher.max_hypotheses) == (5, 3)
    assert matcher.db_params == PEER_DB_DEFAULTS


def test_astrometry_settings(database):
    matcher = get_matcher("astrometry")(database, cpulimit_s=5)
    assert (matcher.settings.scale_tolerance, matcher.settings.cpulimit_s) == (0.05, 5.0)
    with pytest.raises(ValueError, match="could not convert"):
        get_matcher("astrometry")(database, scale_tolerance="wide")
