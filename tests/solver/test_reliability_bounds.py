"""Issue 48, bounds and one-line errors: arrays meet the pixel limit, a sequence of any
length is never listed up front, a sidecar's sky on a device is refused like the same path
on the command line, absurd catalogs are refused, every search has a default time budget,
and a Solver pickles."""

from __future__ import annotations

import json
import pickle
import re
import time

import numpy as np
import pandas as pd
import pytest

import startrack
from startrack.defaults import DEFAULT_TIMEOUT_MS
from startrack.errors import InputError
from startrack.sky._user_catalog import parse_catalog
from tests.cli.test_reliability import cli, one_error


def test_a_huge_array_is_refused_by_the_pixel_limit_at_once():
    image = np.zeros((2, 10**9), np.uint8)  # calloc'd: no page is touched unless read
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="STARTRACK_MAX_IMAGE_PIXELS"):
        startrack.solve(image, fov_deg=20)
    assert time.perf_counter() - t0 < 30  # was 30 s and 7.7 GB, then MemoryError
    with pytest.raises(ValueError, match="centroids, above the limit"):
        startrack.solve(np.zeros((10**8, 2), np.uint8), fov_deg=20)


def test_a_sequence_of_any_length_is_counted_never_listed():
    from startrack.outputs import iterate

    frames = iterate(range(10**15), desc="simulate", unit="frame", quiet=True)
    assert [next(frames) for _ in range(3)] == [0, 1, 2]
    frames.close()


def test_a_sidecar_sky_on_a_device_is_refused_like_the_command_lines(tmp_path):
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    spots = tmp_path / "frame.csv"
    spots.write_text("x,y,flux\n" + "".join(f"{10 * k},{5 * k},{100 - k}\n"
                                            for k in range(10)))
    sidecar = {"camera": {"width": 256, "height": 256, "fov_deg": 17.5},
               "sky": {"kind": "file", "path": str(tmp_path / "zero.csv")}}
    (tmp_path / "frame.json").write_text(json.dumps(sidecar))
    result = cli("identify", spots)
    assert result.returncode == 2 and "zero.csv: not a regular file" in result.stderr
    assert "Traceback" not in result.stderr
    one_error(cli("identify", spots, "--sky", tmp_path / "zero.csv"), "zero.csv")


@pytest.mark.parametrize("text, words", [
    ("ra,dec,mag,pm_ra,epoch\n1,2,3,1e300,3000\n", "pm_ra 1e+300 is outside"),
    ("ra,dec,mag,pm_dec\n1,2,3,-2e5\n", "pm_dec -200000 is outside"),
])
def test_absurd_proper_motions_are_refused(tmp_path, text, words):
    path = tmp_path / "cat.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=re.escape(words)):
        parse_catalog(path)


def _fits_catalog(path, ra, unit) -> None:
    from astropy.io import fits

    rng = np.random.default_rng(1)
    n = len(ra)
    fits.BinTableHDU.from_columns([
        fits.Column(name="RA", format="D", array=ra, unit=unit),
        fits.Column(name="DEC", format="D", array=rng.uniform(-89, 89, n), unit="deg"),
        fits.Column(name="MAG", format="D", array=rng.uniform(0, 6, n)),
    ]).writeto(path)


@pytest.mark.parametrize("unit, words", [("h", "in 'h' (TUNIT)"), (None, "ra in hours?")])
def test_a_fits_catalog_with_ra_in_hours_is_refused_quickly(tmp_path, unit, words):
    path = tmp_path / "hours.fits"
    _fits_catalog(path, np.random.default_rng(0).uniform(0, 24, 5000), unit)
    with pytest.raises(InputError, match=re.escape(words)):
        parse_catalog(path)
    degrees = tmp_path / "degrees.fits"
    _fits_catalog(degrees, np.random.default_rng(0).uniform(0, 360, 5000), "deg")
    assert len(parse_catalog(degrees)["ids"]) == 5000


def test_a_parquet_list_column_is_one_line(tmp_path):
    pytest.importorskip("pyarrow")
    path = tmp_path / "cat.parquet"
    pd.DataFrame({"ra": [1.0, 2.0], "dec": [3.0, 4.0],
                  "mag": [[1.0, 2.0], [3.0]]}).to_parquet(path)
    with pytest.raises(InputError, match="row 1: mag holds a list"):
        parse_catalog(path)
    spots = tmp_path / "frame.csv"
    spots.write_text("x,y\n1,2\n3,4\n5,6\n")
    result = cli("identify", spots, "--fov", "10", "--size", "100x100", "--sky", path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "mag holds a list" in result.stderr


def test_every_search_has_a_default_time_budget():
    from startrack.solver._identifier import Identifier
    from startrack.solver._options import Options

    assert Options().timeout_ms == DEFAULT_TIMEOUT_MS
    import inspect

    assert inspect.signature(Identifier).parameters["timeout_ms"].default == DEFAULT_TIMEOUT_MS
    assert inspect.signature(startrack.Solver).parameters["timeout_ms"].default \
        == DEFAULT_TIMEOUT_MS
    help_text = " ".join(cli("identify", "--help").stdout.split())
    assert "--timeout-ms" in help_text and "default: 60000" in help_text


def test_a_solver_pickles_and_its_copy_answers_the_same():
    from startrack.attitude import from_radec_roll
    from startrack.camera import Camera
    from startrack.simulate import observe
    from startrack.sky import load_sky

    camera = Camera.from_fov(1024, 1024, 20.0)
    scene = observe(load_sky("random", camera), camera, from_radec_roll(120.0, -30.0, 15.0),
                    np.random.default_rng(7))
    spots = np.column_stack([scene.x, scene.y])
    for solver in (startrack.Solver(fov_deg=20.0, size=(1024, 1024), sky="random"),
                   startrack.Solver(camera=camera, sky="random", track=True)):
        first = solver.solve(spots)
        copy = pickle.loads(pickle.dumps(solver))
        again = copy.solve(spots)
        assert first.solved and again.solved
        assert again.ra_deg == pytest.approx(first.ra_deg, abs=1e-9)
        assert again.mode == "lost_in_space"  # a copy starts its own sequence
