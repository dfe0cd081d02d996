"""The simulator's space environment: cosmic rays, stray light and its exclusion angle,
a bright body in the field (docs/simulation.md, the environment rows)."""

import math

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.simulate._effects import Effects
from startrack.simulate._environment import ELECTRONS_PER_UM, SAA_FLUX, Environment
from startrack.simulate._render_effects import expected_with_effects
from startrack.simulate._sensor import SensorModel
from tests.simulate.test_sim_optics import spots

CAM = Camera.from_fov(512, 512, 10.0)
DARK = SensorModel(sky_background=0.0, dark_current=0.0)


def expected(env, sensor=DARK, seed=0, scene=None):
    scene = spots([[256.0, 256.0]], mag=30.0) if scene is None else scene
    return expected_with_effects(scene, CAM, sensor, Effects(environment=env),
                                 np.random.default_rng(seed))


def test_cosmic_ray_hits_follow_the_flux():
    env = Environment(cosmic_rays=SAA_FLUX, pixel_size_um=10.0)
    mean = SAA_FLUX * (512 * 10e-4) ** 2 * DARK.exposure_s  # flux x area (cm^2) x time
    n = [len(env.cosmic_tracks(CAM, DARK.exposure_s, np.random.default_rng(s))[0])
         for s in range(200)]
    assert np.mean(n) == pytest.approx(mean, rel=0.05)
    assert np.var(n) == pytest.approx(mean, rel=0.3)  # Poisson: variance = mean
    image = expected(env)
    # every hit leaves 80 e-/um over at least the depth (some runs off the edge)
    assert image.sum() > 0.8 * mean * ELECTRONS_PER_UM * env.depth_um


def test_heavier_flux_keeps_the_lighter_ones_hits():
    light = expected(Environment(cosmic_rays=1000.0, pixel_size_um=20.0), seed=4)
    heavy = expected(Environment(cosmic_rays=4000.0, pixel_size_um=20.0), seed=4)
    hit = light > 1.0  # (the scene's one star is of magnitude 30: ~1e-7 e-)
    assert hit.sum() > 10
    assert np.all(heavy[hit] >= light[hit] - 1e-9)
    assert heavy.sum() > 2.5 * light.sum()


def test_grazing_hits_leave_tracks_and_steep_ones_spots():
    env = Environment(cosmic_rays=20000.0, depth_um=20.0, pixel_size_um=5.0)
    rows, cols, charge = env.cosmic_hits(CAM, 0.1, np.random.default_rng(1))
    image = np.zeros((512, 512))
    np.add.at(image, (rows, cols), charge)
    from scipy import ndimage

    labels, n = ndimage.label(image > 0, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    assert sizes.min() <= 2 and sizes.max() >= 10  # spots and tracks both


def test_stray_light_is_a_gradient_towards_its_source():
    sensor = SensorModel(sky_background=0.0, dark_current=0.0, exposure_s=1.0)
    env = Environment(stray_light=500.0, stray_gradient=3.0, stray_angle_deg=0.0)
    image = expected(env, sensor)
    centre = image[256, 255:257].mean()
    assert centre == pytest.approx(500.0, rel=0.01)
    left, right = image[256, 0], image[256, -1]
    assert right > centre > left  # brighter towards the source (+x)
    # across the whole diagonal the light rises by 1 + stray_gradient
    half = 0.5 * math.hypot(512, 512)
    assert right / left == pytest.approx(4.0 ** (511 / 2 / half), rel=0.01)
    up = expected(Environment(stray_light=500.0, stray_angle_deg=90.0), sensor)
    assert up[-1, 256] > up[0, 256]


def test_a_source_inside_the_exclusion_angle_blinds_the_tracker():
    env = Environment(stray_light=10.0, source_angle_deg=20.0, exclusion_deg=30.0)
    assert env.blinded
    assert expected(env).min() >= DARK.full_well
    assert not Environment(source_angle_deg=40.0, exclusion_deg=30.0).blinded


def test_the_moon_in_the_field_is_a_disk_of_its_light():
    env = Environment(body_mag=-12.7, body_radius_deg=0.26, body_x=200.0, body_y=300.0)
    image = expected(env)
    radius = CAM.f_px * math.tan(math.radians(0.26))
    assert image.sum() == pytest.approx(float(DARK.electrons_from_mag(-12.7)), rel=1e-6)
    lit = image > 0.5 * image.max()
    assert lit.sum() == pytest.approx(math.pi * radius**2, rel=0.05)
    ys, xs = np.nonzero(lit)
    assert xs.mean() == pytest.approx(200.0, abs=0.5) and ys.mean() == pytest.approx(300.0,
                                                                                      abs=0.5)
