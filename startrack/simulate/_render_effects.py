"""The expected electrons of a frame with effects on: optics (shaped PSFs, tangential
distortion, vignetting), the detector's fixed patterns, dark current with temperature,
rolling shutter and blooming, and the space environment (stray light, cosmic rays, a
bright body). :func:`startrack.simulate._render.render_frame` calls this only when an
effect is on, so frames without effects are today's, draw for draw.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import ndtri, pdtr

from startrack._core.simulate import effects as ek
from startrack._core.simulate import render as rk
from startrack.camera import Camera
from startrack.simulate import _noise
from startrack.simulate._effects import Effects
from startrack.simulate._render import deposit_gaussians, digitise, readout_chain
from startrack.simulate._scene import Scene
from startrack.simulate._sensor import SensorModel

_OVERSAMPLE = 4  # sub-samples per pixel side of a shaped spot


def _tracks(scene: Scene, camera: Camera, effects: Effects, rate_dps, exposure_s: float,
            steps: int, movers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sub-exposure positions (steps x N) of the moving spots, each row of the detector
    exposed at its own time (rolling shutter) around the frame's mid-time."""
    x, y = effects.optics.tangential(camera, scene.x[movers], scene.y[movers])
    turning = rate_dps is not None and any(rate_dps)
    if not turning:
        return x[None, :], y[None, :]
    steps = max(steps, 1)
    v0 = camera.pixel_to_vector(scene.x[movers], scene.y[movers])
    row_t = effects.detector.row_times(scene.y[movers], camera.height)
    omega = np.radians(np.asarray(rate_dps, dtype=np.float64))
    xs, ys = [], []
    for k in range(steps):  # a loop over the few sub-steps, vectorised over stars
        t = ((k + 0.5) / steps - 0.5) * exposure_s + row_t
        turned = Rotation.from_rotvec(-t[:, None] * omega[None, :]).apply(v0)
        px, py, _ = camera.vector_to_pixel(turned.reshape(-1, 3))
        px, py = effects.optics.tangential(camera, px, py)
        xs.append(px)
        ys.append(py)
    return np.array(xs), np.array(ys)


def _deposit(image: np.ndarray, camera: Camera, effects: Effects, x, y, electrons,
             sigma: float) -> None:
    optics = effects.optics
    if not optics.shaped:
        deposit_gaussians(image, x, y, electrons, sigma)
        return
    s = optics.spots(camera, x, y, electrons, sigma)
    _stamps(image, s)


def _stamps(image: np.ndarray, s: dict) -> None:
    reach = np.where(s["model"] == 1, 4.0 * s["a"],
                     np.where(s["model"] == 2, s["a"] + 4.0 * s["b"], 4.0 * s["a"]))
    half = np.ceil(np.maximum(reach, 4.0 * s["b"])).astype(np.int64) + 1
    # sub-samples: 4 x 4 a pixel for sharp spots, 2 x 2 where the PSF is smooth over a
    # pixel (sigma or ring radius of 1 px and more: the midpoint rule is then within
    # ~1% per pixel and exact in total, as every spot is normalised)
    sharp = np.minimum(s["a"], s["b"]) < 1.0
    oversample = np.where(sharp | ((s["model"] == 1) & (s["a"] < 3.0)), _OVERSAMPLE, 2)
    table = np.column_stack([np.asarray(s[k], np.float64) for k in
                             ("x", "y", "electrons", "a", "b", "cos", "sin")])
    ek.deposit_spots(image, np.ascontiguousarray(table),
                     np.ascontiguousarray(s["model"], np.int32),
                     np.ascontiguousarray(half, np.int64),
                     np.ascontiguousarray(oversample, np.int32))


def _body(image: np.ndarray, camera: Camera, sensor: SensorModel, effects: Effects) -> None:
    disk = effects.environment.body_disk(camera)
    if disk is None:
        return
    x, y, radius = disk
    e = sensor.electrons_from_mag(effects.environment.body_mag)
    e = e * float(effects.optics.relative_illumination(camera, x, y))
    sigma = sensor.psf_sigma_px
    one = np.ones(1)
    _stamps(image, {"x": one * x, "y": one * y, "electrons": one * e,
                    "model": np.full(1, 2 if radius > 0.5 else 0, np.int32),
                    "a": one * (radius if radius > 0.5 else sigma), "b": one * sigma,
                    "cos": one, "sin": 0 * one})


@lru_cache(maxsize=4)
def _background(camera: Camera, sensor: SensorModel, effects: Effects) -> np.ndarray | float:
    """Electrons every frame of this camera, sensor and effects expects per pixel before
    its stars: sky (vignetted) and stray light through the PRNU, plus dark current through
    the DSNU. The same in every frame, so it is computed once (a float for a flat one)."""
    optics, det, env = effects.optics, effects.detector, effects.environment
    shape = (camera.height, camera.width)
    sky = sensor.sky_background * sensor.exposure_s
    dark = sensor.dark_current * sensor.exposure_s * det.dark_factor()
    vignetting = optics.illumination_map(camera)
    stray = env.stray_map(camera, sensor.exposure_s)
    prnu, dsnu = det.prnu_map(shape), det.dsnu_map(shape)
    if vignetting is None and stray is None and prnu is None and dsnu is None:
        return sky + dark
    light = np.full(shape, sky, np.float32) if vignetting is None else vignetting * np.float32(
        sky)
    if stray is not None:
        light += stray
    if prnu is not None:
        light *= prnu
    light += np.float32(dark) if dsnu is None else dsnu * np.float32(dark)
    light.setflags(write=False)
    return light


def expected_with_effects(scene: Scene, camera: Camera, sensor: SensorModel, effects: Effects,
                          rng: np.random.Generator, *, angular_rate_dps=None,
                          blur_steps: int = 8, bv: np.ndarray | None = None) -> np.ndarray:
    """The noiseless electron image (H x W float64) of ``scene`` with ``effects``; ``rng``
    draws the environment's randomness (cosmic rays) and nothing else. ``bv``: the B-V
    colour of each scene star (NaN: unknown), for the band model."""
    shape = (camera.height, camera.width)
    optics, det, env = effects.optics, effects.detector, effects.environment
    if env.blinded:  # the source is inside the exclusion angle: the baffle cannot help
        return np.full(shape, 2.0 * sensor.full_well)
    image = np.zeros(shape, dtype=np.float64)
    hot = scene.hot_pixel
    movers = ~hot
    xs, ys = _tracks(scene, camera, effects, angular_rate_dps, sensor.exposure_s,
                     blur_steps, movers)
    steps = xs.shape[0]
    electrons = sensor.electrons_from_mag(scene.mag)
    if bv is not None and not effects.band.is_off:
        electrons = electrons * effects.band.colour_factor(bv)
    electrons = electrons[movers] / steps
    lit = electrons[None, :] * optics.relative_illumination(camera, xs, ys)
    blob = (scene.is_false & ~hot)[movers]
    for sel, sigma in ((~blob, sensor.psf_sigma_px),
                       (blob, sensor.psf_sigma_px * sensor.blob_sigma_factor)):
        if sel.any():
            _deposit(image, camera, effects, xs[:, sel].ravel(), ys[:, sel].ravel(),
                     lit[:, sel].ravel(), sigma)
    _body(image, camera, sensor, effects)
    prnu, background = det.prnu_map(shape), _background(camera, sensor, effects)
    if all(isinstance(m, np.ndarray) and m.dtype == np.float32 and m.flags.c_contiguous
           for m in (prnu, background)):  # one pass over the frame, not two
        ek.shade_and_add(image, prnu, background)
    else:
        if prnu is not None:
            image *= prnu
        image += background
    if hot.any():  # detector defects: one pixel, neither vignetted nor moving
        col = np.floor(scene.x[hot] + 0.5).astype(np.int64)
        row = np.floor(scene.y[hot] + 0.5).astype(np.int64)
        ok = (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)
        np.add.at(image, (row[ok], col[ok]), sensor.electrons_from_mag(scene.mag[hot])[ok])
    rows, cols, charge = env.cosmic_hits(camera, sensor.exposure_s, rng)
    np.add.at(image, (rows, cols), charge)
    if det.blooming:  # only the columns with an overflowing pixel (row-major search)
        columns = np.flatnonzero(image.max(axis=0) > sensor.full_well).astype(np.int64)
        ek.bloom_columns(image, float(sensor.full_well), columns)
    return image


_STEP = 8  # Poisson levels per electron tabulated for the field read-out
_LEVELS = 128 * _STEP  # up to 128 e- (brighter pixels: PTRS)
_BUCKETS = 256  # guide-table buckets per level: mostly no search step
# the skewness of a pixel's read-out (Poisson shot plus Gaussian read noise) below which
# its shot noise is drawn Gaussian: the bound the default chain accepts above 1000 e-
# (1 / sqrt(1000)), where the read noise cannot hide it
_SKEWNESS = 1.0 / np.sqrt(rk.GAUSS_ABOVE)


@lru_cache(maxsize=1)
def _tables() -> tuple[np.ndarray, ...]:
    """The field read-out's tables: normal quantiles at 2^12 + 1 even probabilities (the
    two ends infinite: their cells are drawn exactly; the interpolated inner cells give
    the variance within 1e-4), 1 / k for k < 64, and the Poisson CDF of each level
    n / ``_STEP`` (k up to lam + 12 sqrt(lam) + 30, beyond which the mass is below 1e-30;
    the last value infinite so every draw stops), their starts in the flat CDF array and
    their guide tables."""
    quantiles = ndtri(np.linspace(0.0, 1.0, 2**12 + 1))
    reciprocal = 1.0 / np.maximum(np.arange(64, dtype=np.float64), 1.0)
    cdfs, guides = [], []
    for n in range(_LEVELS):  # once per process
        lam = n / _STEP
        cdf = pdtr(np.arange(int(lam + 12.0 * np.sqrt(lam) + 30.0) + 1.0), lam)
        cdf[-1] = np.inf
        cdfs.append(cdf)
        guides.append(np.searchsorted(cdf, np.arange(_BUCKETS) / _BUCKETS, side="right"))
    start = np.concatenate(([0], np.cumsum([len(c) for c in cdfs]))).astype(np.int64)
    return (quantiles, reciprocal, np.concatenate(cdfs), start,
            np.concatenate(guides).astype(np.int32))


def digitise_field(expected: np.ndarray, sensor: SensorModel, rng: np.random.Generator,
                   nonlinearity: float = 0.0) -> np.ndarray:
    """:func:`startrack.simulate._render.digitise` for frames with effects: a frame whose
    pixels share one sky value takes its exact table; one whose pixels each expect their
    own (vignetting, stray light, PRNU, DSNU) is read out in one compiled pass
    (:func:`startrack._core.simulate.effects.field_pixels`: exact Poisson, but a Gaussian of the
    same
    mean and variance where the read-out's skewness is below ``_SKEWNESS``: above 1000 e-,
    as the default chain, and wherever the read noise hides the Poisson shape). Every
    draw comes from ``rng``."""
    flat = np.ascontiguousarray(expected, dtype=np.float64).ravel()
    if _noise.flat_value(flat) is not None:
        return digitise(expected, sensor, rng, nonlinearity)
    out = np.empty(flat.shape, np.uint16)
    state = rng.integers(1, 2**63, size=4, dtype=np.int64).astype(np.uint64)
    chain = readout_chain(sensor, nonlinearity)
    constants = np.array([chain.full_well, chain.read_noise, chain.gain, chain.bias,
                          chain.adc_max, chain.nonlinearity, _SKEWNESS, _STEP])
    ek.field_pixels(flat, state, constants, out, *_tables())
    return out.reshape(expected.shape)


__all__ = ["digitise_field", "expected_with_effects"]
