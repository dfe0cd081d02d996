"""Peer solvers (tetra3, tetra3rs) behind the matcher interface: conventions and failures.

The peer's own attitude (converted to our frame) is compared with the truth on exact
centroids: half a pixel of origin error is 35 arcsec at this scale, an (x, y) or width/height
swap is far more, so these tests pin down the pixel and frame conventions. Fast tests use a
smaller peer database (fewer patterns per field); the slow test uses the peers' defaults.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
from synth import synthetic_frame
from waiting import run_python

from startrack.attitude import (
    angle_between_deg,
    boresight_error_arcsec,
    from_quaternion,
    random_attitudes,
)
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.match_records import Observation
from startrack.matchers import available_methods, get_matcher
from startrack.sky import SkySpec, load_sky
from startrack.solver import identify

PEERS = ("tetra3", "tetra3rs")
# A smaller database, and a short timeout so that a frame with no answer (tetra3 then
# tries every 4-star pattern) costs half a second, not the peers' default 5 s.
SMALL_DB = {"lattice_field_oversampling": 20, "patterns_per_lattice_field": 20,
            "solve_timeout_ms": 500}
SIZES = ((1024, 1024), (1024, 768))


@pytest.fixture(scope="module")
def catalog():
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), Camera.from_fov(1024, 1024, 20.0))


_matchers: dict = {}


def peer_matcher(name: str, catalog, size: tuple[int, int], **params):
    """A prepared peer matcher for ``size`` (cached per module: the builds take seconds)."""
    pytest.importorskip(name)
    key = (name, size, tuple(sorted(params.items())))
    if key not in _matchers:
        camera = Camera.from_fov(size[0], size[1], 20.0)
        matcher = get_matcher(name)(StarDatabase(catalog, camera), **params)
        matcher.prepare()
        _matchers[key] = matcher
    return _matchers[key]


def frames(catalog, size, n, seed, **kw):
    camera = Camera.from_fov(size[0], size[1], 20.0)
    rng = np.random.default_rng(seed)
    return [synthetic_frame(catalog, camera, rot, rng, **kw) for rot in random_attitudes(n, rng)]


def test_peers_are_registered():
    assert set(PEERS) <= set(available_methods())


@pytest.mark.parametrize("name", PEERS)
def test_missing_peer_is_a_clean_input_error(name, catalog, monkeypatch):
    monkeypatch.setitem(sys.modules, name, None)  # makes `import name` fail
    matcher = get_matcher(name)(StarDatabase(catalog, Camera.from_fov(1024, 1024, 20.0)))
    with pytest.raises(InputError) as err:
        matcher.prepare()
    assert str(err.value) == f"{name} needs the peers extra: pip install 'startrack[peers]'"


def test_registry_loads_without_the_peers():
    code = (
        "import sys; sys.modules['tetra3'] = None; sys.modules['tetra3rs'] = None\n"
        "from startrack.matchers import available_methods, get_matcher\n"
        "from startrack.errors import InputError\n"
        "assert {'tetra3', 'tetra3rs'} <= set(available_methods())\n"
        "m = get_matcher('tetra3rs')\n"
        "try:\n"
        "    m(None).prepare()\n"
        "except InputError as e:\n"
        "    print(e)\n")
    expected = "tetra3rs needs the peers extra: pip install 'startrack[peers]'"
    assert run_python(code).strip() == expected


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("name", PEERS)
def test_exact_centroids_peer_attitude_and_identities(name, size, catalog):
    matcher = peer_matcher(name, catalog, size, **SMALL_DB)
    for fr in frames(catalog, size, 4, seed=11):
        sol = identify(fr.obs, matcher)
        assert sol.solved
        assert sol.diagnostics.method_ms > 0
        np.testing.assert_array_equal(sol.cat_index, fr.truth_rows[sol.obs_index])
        assert len(sol.obs_index) >= 0.9 * len(fr.obs)
        assert angle_between_deg(sol.rotation, fr.rotation) * 3600 < 1.0
        peer = from_quaternion(sol.diagnostics.extra["peer_quaternion"])
        assert angle_between_deg(peer, fr.rotation) * 3600 < 2.0  # half a pixel: 35"


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("name", PEERS)
def test_noisy_centroids_with_false_stars(name, size, catalog):
    matcher = peer_matcher(name, catalog, size, **SMALL_DB)
    solved = 0
    for fr in frames(catalog, size, 6, seed=5, noise_px=0.3, false_stars=2, missing=0.1):
        sol = identify(fr.obs, matcher)
        if not sol.solved:
            continue
        solved += 1
        np.testing.assert_array_equal(sol.cat_index, fr.truth_rows[sol.obs_index])
        # 0.3 px over ~50 stars: a few arcsec of boresight, tens of arcsec of roll.
        assert boresight_error_arcsec(sol.rotation, fr.rotation) < 15.0
        peer = from_quaternion(sol.diagnostics.extra["peer_quaternion"])
        assert boresight_error_arcsec(peer, fr.rotation) < 20.0
        assert angle_between_deg(peer, fr.rotation) * 3600 < 120.0
    assert solved >= 5


@pytest.mark.parametrize("name", PEERS)
def test_random_centroids_and_too_few_stars_are_not_solved(name, catalog):
    matcher = peer_matcher(name, catalog, (1024, 1024), **SMALL_DB)
    camera = matcher.database.camera
    rng = np.random.default_rng(3)
    for _ in range(3):
        n = int(rng.integers(20, 60))
        obs = Observation.from_pixels(rng.uniform(0, 1023, n), rng.uniform(0, 1023, n),
                                      camera, 0.3)
        assert not identify(obs, matcher).solved
    fr = frames(catalog, (1024, 1024), 1, seed=4)[0]
    three = Observation.from_pixels(fr.obs.x[:3], fr.obs.y[:3], camera, 0.05)
    assert not identify(three, matcher).solved


@pytest.mark.slow
@pytest.mark.parametrize("name", PEERS)
def test_default_peer_database_solves_noisy_frames(name, catalog):
    matcher = peer_matcher(name, catalog, (1024, 1024))
    for fr in frames(catalog, (1024, 1024), 10, seed=8, noise_px=0.3, false_stars=3,
                     missing=0.1):
        sol = identify(fr.obs, matcher)
        assert sol.solved
        np.testing.assert_array_equal(sol.cat_index, fr.truth_rows[sol.obs_index])
