"""Regression tests of the hostile-input sweep: each case is one line and exit 2, or a clean
exception through the API; legal inputs that were refused are read (docs/limits.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from startrack.cli import main


def run(*args, env=None):
    result = CliRunner().invoke(main, [str(a) for a in args], env=env, catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


def one_line_error(code, stderr, *words) -> None:
    assert code == 2, stderr
    assert len(stderr.splitlines()) == 1 and "Traceback" not in stderr, stderr
    for word in words:
        assert word in stderr, stderr


@pytest.fixture(scope="module")
def frame_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("validation") / "frame.csv"
    path.write_text("x,y\n" + "".join(f"{100 + 37 * i},{200 + 53 * i}\n" for i in range(8)))
    return path


@pytest.mark.parametrize(("args", "option"), [
    (["--fov", "1e-300"], "--fov"),
    (["--sigma-px", "1e200"], "--sigma-px"),
    (["--fov-tolerance", "nan"], "--fov-tolerance"),
    (["--epoch", "1e308"], "--epoch"),
    (["--prior", "1e300,0,0"], "--prior"),
    (["--size", "0x3"], "--size"),
])
def test_identify_numbers_out_of_range_are_one_line(frame_csv, tmp_path, args, option):
    out = tmp_path / "out.json"
    code, _, err = run("identify", frame_csv, "--output", out, *args)
    one_line_error(code, err, option)
    assert not out.exists()


def test_sigma_message_names_the_range(frame_csv):
    _, _, err = run("identify", frame_csv, "--sigma-px", "1e200")
    assert "--sigma-px: 1e+200 is out of range (0, 50]" in err


def test_calibrate_tiny_fov_is_one_line(frame_csv, tmp_path):
    out = tmp_path / "camera.json"
    code, _, err = run("calibrate", frame_csv, "--fov", "1e-300", "--size", "1024x1024",
                       "--output", out)
    one_line_error(code, err, "--fov")
    assert not out.exists()


@pytest.mark.parametrize(("args", "option"), [
    (["--fps", "1e-300"], "--fps"),
    (["--false-stars", "300000"], "--false-stars"),
    (["--rate", "1e300,0,0"], "--rate"),
    (["--attitude", "0,91,0"], "--attitude"),
])
def test_simulate_numbers_out_of_range_are_one_line(tmp_path, args, option):
    code, _, err = run("simulate", "--out", tmp_path / "sim", *args)
    one_line_error(code, err, option)
    assert not (tmp_path / "sim").exists()


def test_compare_false_stars_bounded(tmp_path):
    code, _, err = run("compare", "--false-stars", "0,300000", "--out", tmp_path / "c")
    one_line_error(code, err, "--false-stars")


def test_compare_jobs_capped_at_the_cores(capsys, monkeypatch):
    from startrack.cli import _compare as compare

    monkeypatch.setattr(compare.os, "cpu_count", lambda: 2)
    assert compare._workers(12) == 2
    assert "--jobs 12 is more than the 2 CPU(s)" in capsys.readouterr().err
    assert compare._workers(None) == 2 and compare._workers(1) == 1


@pytest.mark.parametrize("value", ["nan", "inf", "1e400", "-5", "lots"])
def test_cache_cap_environment_is_one_line(value):
    code, _, err = run("cache", "info", env={"STARTRACK_CACHE_MAX_MB": value})
    one_line_error(code, err, "STARTRACK_CACHE_MAX_MB")


def test_max_image_pixels_environment_honoured(monkeypatch, tmp_path):
    from startrack.io import max_image_pixels

    monkeypatch.setenv("STARTRACK_MAX_IMAGE_PIXELS", "1e9")
    assert max_image_pixels() == 10**9
    monkeypatch.setenv("STARTRACK_MAX_IMAGE_PIXELS", "100")
    png = tmp_path / "small.png"
    import cv2

    cv2.imwrite(str(png), np.zeros((20, 20), np.uint8))
    code, _, err = run("identify", png, "--fov", "10")
    assert code == 2 and "STARTRACK_MAX_IMAGE_PIXELS" in err


# The API


def test_api_time_as_a_julian_year():
    from startrack.api._keywords import api_time

    assert abs(api_time(2019).jyear - 2019.0) < 1e-9
    assert abs(api_time(2019.5).jyear - 2019.5) < 1e-9
    with pytest.raises(ValueError, match="time"):
        api_time(1e300)
    with pytest.raises(TypeError, match="time"):
        api_time(True)


def test_api_camera_as_a_mapping():
    from startrack.api._keywords import api_camera

    camera = api_camera({"width": 1024, "height": 768, "fov_deg": 10.0})
    assert (camera.width, camera.height) == (1024, 768)
    assert abs(camera.fov_deg - 10.0) < 1e-9
    with pytest.raises(ValueError, match="camera: fov_deg"):
        api_camera({"width": 1024, "height": 768, "fov_deg": 1e-300})
    with pytest.raises(ValueError, match="unknown key"):
        api_camera({"width": 1024, "height": 768, "fov_deg": 10, "focus": 3})
    with pytest.raises(TypeError, match="camera"):
        api_camera(42)


def test_api_prior_needs_ra_dec_roll():
    import startrack

    with pytest.raises(TypeError, match=r"prior: expected \(ra, dec, roll\)"):
        startrack.Solver(fov_deg=17.5, sky="random", prior=(1, 2))
    with pytest.raises(ValueError, match="prior: dec"):
        startrack.Solver(fov_deg=17.5, sky="random", prior=(1, 95, 0))


def test_api_integer_centroid_array_is_centroids():
    from startrack.api import as_frame_input

    frame = as_frame_input(np.array([[10, 20], [30, 40], [50, 60]], dtype=np.int64))
    assert frame.centroids is not None and len(frame.centroids.x) == 3
    assert frame.centroids.x.tolist() == [10.0, 30.0, 50.0]
    with pytest.raises(TypeError, match="complex"):
        as_frame_input(np.ones((8, 8), np.complex64))


@pytest.mark.parametrize(("keyword", "value"), [
    ("fov_deg", 1e-300), ("sigma_px", 1e200), ("fov_tolerance", float("nan")),
    ("epoch", 1e308), ("max_stars", 2), ("timeout_ms", -1),
])
def test_api_numbers_out_of_range(keyword, value):
    import startrack

    options = {"fov_deg": 17.5, "sky": "random", keyword: value}
    with pytest.raises(ValueError, match=keyword):
        startrack.Solver(**options)


# Dates


@pytest.mark.parametrize(("text", "isot"), [
    ("2016-12-31T23:59:60.5", "2016-12-31T23:59:60.500"),
    ("2016-12-31T23:59:60.5Z", "2016-12-31T23:59:60.500"),
    ("29/07/19", "1919-07-29T00:00:00.000"),
])
def test_legal_dates_are_read(text, isot):
    from startrack.solver import parse_time

    assert parse_time(text).utc.isot == isot


@pytest.mark.parametrize("text", ["2015-12-31T23:59:60.5", "0999-01-01", "31/02/19", "soon"])
def test_bad_dates_are_refused(text):
    from startrack.solver import parse_time

    with pytest.raises(ValueError, match="--time"):
        parse_time(text)


# Files


def test_fits_declaring_a_huge_table_is_refused_before_reading(tmp_path):
    from astropy.io import fits

    path = tmp_path / "table.fits"
    table = fits.BinTableHDU.from_columns([fits.Column(name="a", format="D",
                                                       array=np.zeros(3))])
    fits.HDUList([fits.PrimaryHDU(), table]).writeto(path)
    raw = bytearray(path.read_bytes())
    at = raw.find(b"NAXIS2  =", 2880)
    raw[at:at + 80] = f"NAXIS2  = {2_000_000_000:20d}".ljust(80).encode()
    path.write_bytes(bytes(raw))
    assert path.stat().st_size < 9000
    code, _, err = run("identify", path, "--fov", "10")
    one_line_error(code, err, "declares", "HDU 1")


def test_complex_tiff_is_refused(tmp_path):
    import tifffile

    path = tmp_path / "complex.tif"
    tifffile.imwrite(path, (np.ones((32, 32)) + 1j).astype(np.complex64))
    code, _, err = run("identify", path, "--fov", "10")
    one_line_error(code, err, "complex")


def test_truncated_tiff_prints_only_our_line(tmp_path):
    import tifffile

    whole = tmp_path / "whole.tif"
    tifffile.imwrite(whole, np.zeros((64, 64), np.uint16), description="x" * 40)
    cut = tmp_path / "cut.tif"
    cut.write_bytes(whole.read_bytes()[:200])
    code, _, err = run("identify", cut, "--fov", "10")
    one_line_error(code, err, "cut.tif")


def test_library_warnings_become_one_note_or_nothing():
    import warnings

    from startrack.cli._quiet import library_noise_captured

    class ErfaWarning(UserWarning):
        pass

    runner = CliRunner()
    with runner.isolation() as (_, _, err), library_noise_captured():
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        for _ in range(3):
            warnings.warn('ERFA function "dtf2d" yielded 1 of "dubious year"', ErfaWarning,
                          stacklevel=1)
        import logging

        logging.getLogger("tifffile").warning("<TiffTag.fromfile> raised TiffFileError")
        text = err.getvalue().decode()
    assert text.count("\n") == 1 and "leap-second table" in text


def test_camera_file_numbers_name_the_file(tmp_path):
    path = tmp_path / "cam.json"
    path.write_text(json.dumps({"width": 1024, "height": 1024, "fov_deg": 1e-300}))
    code, _, err = run("identify", tmp_path / "missing.csv", "--camera", path)
    one_line_error(code, err, "cam.json: fov_deg")


def test_wrong_prior_falls_back_and_says_so():
    from synth import synthetic_frame

    import startrack
    from startrack.attitude import from_radec_roll
    from startrack.camera import Camera
    from startrack.sky import random_sky

    camera = Camera.from_fov(1024, 1024, 17.5)
    frame = synthetic_frame(random_sky(2000, seed=0), camera, from_radec_roll(120, 40, 10),
                            np.random.default_rng(5))
    xy = np.column_stack([frame.obs.x, frame.obs.y])
    options = dict(fov_deg=17.5, size=(1024, 1024), sky="random", fov_tolerance=0)
    plain = startrack.solve(xy, **options)
    wrong = startrack.solve(xy, prior=(0, 0, 0), prior_sigma_deg=0.001, **options)
    assert plain.solved and wrong.solved and wrong.mode == "lost_in_space"
    assert wrong.to_dict()["fallback"] == "no_track" and "fallback" not in plain.to_dict()
    near = startrack.solve(xy, prior=(120, 40, 10), prior_sigma_deg=0.5, **options)
    assert near.mode == "tracking" and "fallback" not in near.to_dict()


def test_simulate_stopped_keeps_complete_frames_listed(tmp_path, monkeypatch):
    import startrack.simulate as render  # the command takes it by the front door

    real, calls = render.render_frame, []

    def render_then_stop(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(render, "render_frame", render_then_stop)
    _free_disk(monkeypatch, 10**15)  # a million frames "fit": the run is stopped first
    out = tmp_path / "sim"
    code, _, err = run("simulate", "--frames", "1000000", "--fps", "10", "--out", out)
    assert code == 130 and "stopped after 2 frame(s)" in err
    truth = (out / "truth.csv").read_text().splitlines()
    assert [row.split(",")[1] for row in truth[1:]] == ["frame_0000.png", "frame_0001.png"]
    assert _written(out) == [
        "frame_0000.json", "frame_0000.png", "frame_0001.json", "frame_0001.png",
        "stars.csv", "truth.csv"]


def _written(out) -> list[str]:
    """The files in a run folder, less its lock and manifest (startrack.io._run_folder)."""
    from startrack.io._run_folder import LOCK_FILE, MANIFEST_FILE

    return sorted(p.name for p in out.iterdir() if p.name not in (LOCK_FILE, MANIFEST_FILE))


def _free_disk(monkeypatch, free: int) -> None:
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(free, 0, free))


def test_simulate_refuses_a_run_that_cannot_fit_the_disk(tmp_path, monkeypatch):
    _free_disk(monkeypatch, 10**7)
    out = tmp_path / "sim"
    code, _, err = run("simulate", "--frames", "1000", "--out", out)
    one_line_error(code, err, "1,000 frames need about", "free")
    assert not out.exists() or not _written(out)


def test_sequence_plan_blocks_match_the_whole():
    from startrack.attitude import from_radec_roll
    from startrack.simulate import constant_rate, simulation_trajectory

    r0 = from_radec_roll(10, 20, 30)
    plan = simulation_trajectory(r0, (0.5, -0.2, 1.0), 10.0, None, 1000)
    whole = constant_rate(r0, (0.5, -0.2, 1.0), 10.0, 1000)
    block = plan.block(600, 256)
    assert len(plan) == 1000 and len(block) == 256
    assert ((block.rotations.inv() * whole.rotations[600:856]).magnitude() < 1e-12).all()
    assert len(plan.block(900, 256)) == 100
