"""Turn a scene into a sensor frame: pixel-integrated PSFs, motion blur, noise, ADC."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import erf

from startrack._core.simulate import render as rk
from startrack.camera import Camera
from startrack.simulate import _noise as render_noise
from startrack.simulate._effects import Effects
from startrack.simulate._scene import Scene
from startrack.simulate._sensor import SensorModel

_SQRT2 = math.sqrt(2.0)


def _pixel_fractions(centre: np.ndarray, first: np.ndarray, width: int,
                     sigma: float) -> np.ndarray:
    """Fraction of a 1-D Gaussian falling in pixels first..first+width-1 (N x width).

    Pixel i spans [i - 0.5, i + 0.5], so integrating the PSF over it is a difference
    of error functions at the pixel edges.
    """
    edges = first[:, None] + np.arange(width + 1) - 0.5
    cdf = erf((edges - centre[:, None]) / (_SQRT2 * sigma))
    return 0.5 * np.diff(cdf, axis=1)


def deposit_gaussians(image: np.ndarray, x: np.ndarray, y: np.ndarray,
                      electrons: np.ndarray, sigma: float) -> None:
    """Add pixel-integrated Gaussian spots to ``image`` in place (vectorised over spots).

    Each spot covers a window of +-(4 sigma + 1) pixels; flux that falls outside the
    image is lost, as on a real detector.
    """
    if len(x) == 0:
        return
    h, w = image.shape
    half = int(math.ceil(4.0 * sigma)) + 1
    size = 2 * half + 1
    x0 = np.floor(x + 0.5).astype(np.int64) - half
    y0 = np.floor(y + 0.5).astype(np.int64) - half
    fx = _pixel_fractions(x, x0, size, sigma)
    fy = _pixel_fractions(y, y0, size, sigma)
    values = (electrons[:, None, None] * fy[:, :, None]) * fx[:, None, :]
    cols = x0[:, None] + np.arange(size)
    rows = y0[:, None] + np.arange(size)
    ok = ((rows >= 0) & (rows < h))[:, :, None] & ((cols >= 0) & (cols < w))[:, None, :]
    flat = rows[:, :, None] * w + cols[:, None, :]
    np.add.at(image.reshape(-1), flat[ok], values[ok])


def _blur_tracks(scene: Scene, camera: Camera, rate_dps, exposure_s: float,
                 steps: int, movers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sub-exposure positions (steps x N) of the moving spots.

    The scene attitude is the mid-exposure attitude; with body rate w the attitude at
    time t is R0 * exp(w t), so camera-frame vectors turn by exp(-w t).
    """
    v0 = camera.pixel_to_vector(scene.x[movers], scene.y[movers])
    times = ((np.arange(steps) + 0.5) / steps - 0.5) * exposure_s
    omega = np.radians(np.asarray(rate_dps, dtype=np.float64))
    turns = Rotation.from_rotvec(-times[:, None] * omega[None, :])
    xs, ys = [], []
    for k in range(steps):  # a loop over the few sub-steps, vectorised over stars
        x, y, _ = camera.vector_to_pixel(turns[k].apply(v0).reshape(-1, 3))
        xs.append(x)
        ys.append(y)
    return np.array(xs), np.array(ys)


def render_stars(scene: Scene, camera: Camera, sensor: SensorModel, *,
                 angular_rate_dps: tuple[float, float, float] | None = None,
                 blur_steps: int = 8) -> np.ndarray:
    """Expected electrons (H x W, float64) from the scene's spots alone, no background."""
    image = np.zeros((camera.height, camera.width), dtype=np.float64)
    electrons = sensor.electrons_from_mag(scene.mag)
    hot = scene.hot_pixel
    blob = scene.is_false & ~hot
    movers = ~hot  # hot pixels are detector defects: they do not move with the sky
    if angular_rate_dps is not None and any(angular_rate_dps) and blur_steps > 1:
        xs, ys = _blur_tracks(scene, camera, angular_rate_dps, sensor.exposure_s,
                              blur_steps, movers)
    else:
        xs, ys = scene.x[movers][None, :], scene.y[movers][None, :]
    steps = xs.shape[0]
    e_sub = electrons[movers] / steps
    is_blob = blob[movers]
    for sel, sigma in ((~is_blob, sensor.psf_sigma_px),
                       (is_blob, sensor.psf_sigma_px * sensor.blob_sigma_factor)):
        if sel.any():
            deposit_gaussians(image, xs[:, sel].ravel(), ys[:, sel].ravel(),
                              np.tile(e_sub[sel], steps), sigma)
    if hot.any():
        col = np.floor(scene.x[hot] + 0.5).astype(np.int64)
        row = np.floor(scene.y[hot] + 0.5).astype(np.int64)
        ok = (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)
        np.add.at(image, (row[ok], col[ok]), electrons[hot][ok])
    return image


def render_expected(scene: Scene, camera: Camera, sensor: SensorModel, *,
                    angular_rate_dps: tuple[float, float, float] | None = None,
                    blur_steps: int = 8) -> np.ndarray:
    """The noiseless electron image: stars plus sky background and dark current."""
    image = render_stars(scene, camera, sensor, angular_rate_dps=angular_rate_dps,
                         blur_steps=blur_steps)
    image += sensor.background_electrons
    return image


def digitise(expected: np.ndarray, sensor: SensorModel, rng: np.random.Generator,
             nonlinearity: float = 0.0) -> np.ndarray:
    """Shot noise, full-well clip, read noise, gain, bias and ADC: electrons to counts.

    Pixels at the frame's common sky value draw their count from its exact distribution
    (``render_noise.adu_table``, one compiled uniform draw each); for the others shot noise is exact
    Poisson up to ``startrack._core.simulate.render.GAUSS_ABOVE`` expected electrons and
    Gaussian (same
    mean and variance) above, plus Gaussian read noise. Every draw comes from ``rng``.
    ``nonlinearity``: the ADC's compression at full well (0: linear).
    """
    expected = np.asarray(expected)
    if expected.dtype not in (np.float32, np.float64):
        expected = expected.astype(np.float64)
    flat = np.ascontiguousarray(expected).ravel()
    out = np.empty(flat.shape, np.uint16)
    chain = readout_chain(sensor, nonlinearity)
    lam = render_noise.flat_value(flat)
    table = None if lam is None else render_noise.adu_table(
        lam, chain.full_well, chain.read_noise, chain.gain, chain.bias, chain.adc_max,
        chain.nonlinearity)
    others = np.arange(flat.size) if table is None else _sky_pixels(flat, lam, table, rng, out)
    _pixel_chain(flat[others], others, chain, rng, out)
    return out.reshape(expected.shape)


def readout_chain(sensor: SensorModel, nonlinearity: float = 0.0) -> rk.Readout:
    """The sensor's read-out constants as the compiled noise kernels take them."""
    return rk.Readout(float(sensor.full_well), float(sensor.read_noise), float(sensor.gain),
                      float(sensor.bias_adu), float(sensor.adc_max), float(nonlinearity))


_CHUNK = 1 << 18  # pixels per call: the index scratch stays small whatever the frame


def _sky_pixels(flat, lam, table, rng, out) -> np.ndarray:
    """Counts of the pixels that expect ``lam``; returns the indices of the others."""
    sky = rk.SkyTable(float(flat.dtype.type(lam)), *table)
    # a compiled generator seeded from ``rng`` (never all zero): no array of uniforms
    state = rng.integers(1, 2**63, size=4, dtype=np.int64).astype(np.uint64)
    scratch, parts = np.empty(min(_CHUNK, flat.size), np.int64), []
    for start in range(0, flat.size, _CHUNK):
        stop = min(start + _CHUNK, flat.size)
        n = rk.sky_pixels(flat, start, stop, sky, state, out, scratch)
        parts.append(scratch[:n].copy())
    return np.concatenate(parts)


def _pixel_chain(lam, where, chain, rng, out) -> None:
    """Counts of the pixels ``where`` (expecting ``lam``) into ``out``, pixel by pixel."""
    electrons = np.empty(lam.shape, np.float32)
    rk.shot_noise(lam, rng.random(lam.shape), electrons)
    for mark, draw in ((-1.0, rng.poisson),
                       (-2.0, lambda m: np.rint(m + np.sqrt(m) * rng.standard_normal(
                           m.shape)).clip(0, None))):
        sel = np.flatnonzero(electrons == mark)
        if len(sel):
            electrons[sel] = draw(lam[sel])
    rk.readout(electrons, rng.standard_normal(lam.shape, dtype=np.float32), chain, out, where)


def render_frame(scene: Scene, camera: Camera, sensor: SensorModel, rng: np.random.Generator,
                 *, angular_rate_dps: tuple[float, float, float] | None = None,
                 blur_steps: int = 8, effects: Effects | None = None,
                 effects_rng: np.random.Generator | None = None,
                 bv: np.ndarray | None = None) -> np.ndarray:
    """A noisy frame (uint16, H x W) of the scene as the sensor reads it out.

    ``effects`` (optics, band, detector, environment; none by default) draw their
    randomness from ``effects_rng`` (default: a stream of ``rng``'s), never from ``rng``
    itself, so a frame's pixel noise is the same with and without them. ``bv``: each
    scene star's B-V colour for the [band] model (NaN or None: a Sun-like star)."""
    if effects is None or effects.is_off:
        expected = render_expected(scene, camera, sensor, angular_rate_dps=angular_rate_dps,
                                   blur_steps=blur_steps)
        return digitise(expected, sensor, rng)
    # the effects' renderer (scipy rotations, the effect kernels): when an effect is on
    from startrack.simulate._render_effects import digitise_field, expected_with_effects

    if effects_rng is None:
        effects_rng = np.random.default_rng(rng.bit_generator.seed_seq.spawn(1)[0])
    expected = expected_with_effects(scene, camera, sensor, effects, effects_rng,
                                     angular_rate_dps=angular_rate_dps, blur_steps=blur_steps,
                                     bv=bv)
    return digitise_field(expected, sensor, rng, effects.detector.adc_nonlinearity)
