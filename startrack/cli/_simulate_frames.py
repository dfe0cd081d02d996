"""One frame of `startrack simulate` rendered and written (image, FITS, sidecar) with its
CSV rows, and the disk check of a long run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from startrack.errors import InputError
from startrack.io import atomic_text, sidecar_path_for
from startrack.simulate import SensorModel
from startrack.sky import SkySpec

BLOCK = 256  # sequence attitudes computed this many frames at a time (bounded memory)


class FrameWriter:
    """Renders and writes frame i (image, FITS, sidecar) and gives its CSV rows."""

    def __init__(self, camera, spec, sensor, opts, out, attitude, with_fits, trajectory,
                 obs_time, catalog, effects=None) -> None:
        from startrack.attitude import from_radec_roll

        self.camera, self.spec, self.sensor, self.opts = camera, spec, sensor, opts
        self.out, self.with_fits, self.trajectory = out, with_fits, trajectory
        self.catalog = catalog
        self.effects = effects
        self.bv = None  # the catalog's colours, when the band model needs them
        if effects is not None and not effects.band.is_off:
            from startrack.simulate import catalog_bv

            self.bv = catalog_bv(catalog)
        self.when = None if obs_time is None else obs_time.utc.isot
        self.fixed = from_radec_roll(*attitude) if attitude is not None else None
        self._block: tuple[int, object] | None = None
        #: (frame, files written so far) of the frame being written
        self._partial: tuple[int, list[Path]] = (-1, [])

    def files(self, i: int) -> list[Path]:
        """The files frame i is made of (its FITS only when asked for)."""
        png = self.out / f"frame_{i:04d}.png"
        fits = [self.out / f"frame_{i:04d}.fits"] if self.with_fits else []
        return [png, *fits, sidecar_path_for(png)]

    def remove(self, i: int) -> None:
        """Delete what this run wrote of frame i: a frame being written loses only the
        files it got to (a refused path, an input, stays untouched)."""
        written = self._partial[1] if self._partial[0] == i else self.files(i)
        for path in written:
            path.unlink(missing_ok=True)

    def _pose(self, i: int, rng):
        """Frame i's attitude and rate: the sequence's (--fps), else fixed or random."""
        if self.trajectory is None:
            return (self.fixed if self.fixed is not None else random_rotation(rng),
                    self.opts.rate_dps)
        block = self._sequence_block(i)
        k = i - self._block[0]
        return block.rotations[k], tuple(float(w) for w in block.rates_dps[k])

    def _sequence_block(self, i: int):
        if self._block is None or not 0 <= i - self._block[0] < BLOCK:
            self._block = (i, self.trajectory.block(i, BLOCK))
        return self._block[1]

    def times(self, i: int) -> dict:
        """Frame i's sidecar times: ``time_s`` is the frame's tag; with a time-tag error
        the truth beside it (``true_time_s``, the time it was rendered at, and the error)."""
        block = self._sequence_block(i)
        k = i - self._block[0]
        true = float(block.times[k])
        if block.tag_times is None:
            return {"time_s": true}
        tag = float(block.tag_times[k])
        return {"time_s": tag, "true_time_s": true, "time_tag_error_s": tag - true}

    def write(self, i: int) -> tuple[list, list[list]]:
        from startrack.attitude import to_quaternion, to_radec_roll
        from startrack.io import write_fits, write_png16
        from startrack.outputs import wcs_header
        from startrack.simulate import observe, render_frame

        opts, camera, sensor = self.opts, self.camera, self.sensor
        rng = np.random.default_rng([opts.seed, i])  # each frame reproducible on its own
        rotation, rate_dps = self._pose(i, rng)
        scene = observe(self.catalog, camera, rotation, rng, missing=opts.missing,
                        false_stars=opts.false_stars, mag_noise=opts.mag_noise,
                        hot_pixel_fraction=opts.hot_pixel_fraction)
        # the effects' own stream: the frame's pixel noise is the same with or without them
        image = render_frame(scene, camera, sensor, rng, angular_rate_dps=rate_dps,
                             effects=self.effects,
                             effects_rng=np.random.default_rng([opts.seed, i, 1]),
                             bv=None if self.bv is None else np.where(
                                 scene.catalog_row >= 0, self.bv[scene.catalog_row], np.nan))
        png, *_, sidecar_path = self.files(i)
        written: list[Path] = []
        self._partial = (i, written)
        write_png16(png, image)
        written.append(png)
        if self.with_fits:
            fits_path = png.with_suffix(".fits")
            write_fits(fits_path, image, wcs_header(
                camera, rotation, date_obs=self.when,
                extra=_fits_keywords(sensor, png.name)))
            written.append(fits_path)
        q = [float(c) for c in to_quaternion(rotation)]
        ra, dec, roll = to_radec_roll(rotation)
        sidecar = {
            "image": png.name, "frame": i, "seed": opts.seed,
            "units": SIDECAR_UNITS,
            "camera": camera.to_dict(), "sky": _sky_entry(self.spec),
            "attitude": {"quaternion": q, "ra_deg": ra, "dec_deg": dec, "roll_deg": roll},
            "sensor": sensor.to_dict(), "time_utc": self.when,
            "frames": {"missing": opts.missing, "false_stars": opts.false_stars,
                       "mag_noise": opts.mag_noise, "rate_dps": rate_dps},
        }
        if self.effects is not None and not self.effects.is_off:
            sidecar["effects"] = self.effects.to_dict()
        if self.trajectory is not None:
            sidecar.update(self.times(i))
        with atomic_text(sidecar_path) as fh:
            json.dump(sidecar, fh, indent=2)
            fh.write("\n")
        written.append(sidecar_path)
        flux = sensor.electrons_from_mag(scene.mag)
        # a few dozen rows per frame, for the CSV writer (ids stay exact integers)
        columns = (scene.x, scene.y, flux, scene.mag, scene.catalog_id,
                   np.asarray(scene.is_false, dtype=np.int64))
        stars = [[i, *row] for row in zip(*(np.asarray(c).tolist() for c in columns),
                                          strict=True)]
        return [i, png.name, *q, ra, dec, roll], stars


def check_disk(out: Path, first_files: list[Path], count: int) -> None:
    """Refuse, after the first frame, a run whose frames cannot fit the free space."""
    import shutil

    per_frame = sum(p.stat().st_size for p in first_files if p.exists()) + 4096
    need = per_frame * (count - 1)
    free = shutil.disk_usage(out).free
    if need > free * 0.95:
        raise InputError(f"{out}: {count:,} frames need about {need / 1e9:.3g} GB "
                         f"({per_frame / 1e6:.3g} MB a frame) but only {free / 1e9:.3g} GB "
                         "is free; give fewer --frames")


#: what the numbers in a sidecar are measured in (docs/conventions.md)
SIDECAR_UNITS = {
    "pixels": "px; (0, 0) is the centre of the top-left pixel, x right, y down",
    "angles": "deg (fov_deg, ra_deg, dec_deg, roll_deg, min_separation_deg)",
    "quaternion": "scalar first [w, x, y, z], camera frame to ICRS",
    "rate_dps": "deg/s about the camera axes",
    "magnitudes": "catalog magnitudes (Hipparcos Hp for the Hipparcos sky)",
    "sensor": "electrons (e-), ADU counts, seconds; gain in e-/ADU",
}


def _sky_entry(spec: SkySpec) -> dict:
    """The sky as a sidecar records it: a random sky's size and seed, only for one."""
    entry = spec.to_dict()
    if spec.kind != "random":
        entry.pop("n_stars", None)
        entry.pop("seed", None)
    return entry


def _fits_keywords(sensor: SensorModel, png_name: str) -> dict:
    return {"EXPTIME": (sensor.exposure_s, "[s] exposure time"),
            "GAIN": (sensor.gain, "[e-/ADU] detector gain"),
            "BUNIT": ("adu", "pixel values are detector counts (ADU)"),
            "FRAME": (png_name, "the same frame as PNG")}


def random_rotation(rng: np.random.Generator):
    from startrack.attitude import random_attitudes

    return random_attitudes(1, rng)[0]

__all__ = ["BLOCK", "FrameWriter", "SIDECAR_UNITS", "check_disk", "random_rotation"]
