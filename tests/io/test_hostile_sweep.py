"""Regression tests of the QA re-run of the hostile sweep (issues 30, 31): cases found
beyond the issues' lists, each a one-line answer (docs/limits.md, docs/conventions.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import startrack
from startrack.io._writer import OutputError, Writer
from tests.cli.test_validation import one_line_error, run


def test_identify_output_dash_is_standard_output(tmp_path, monkeypatch):
    # `--output -` wrote a file called "-" in the working folder and printed nothing.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "two.csv").write_text("x,y\n10,20\n30,40\n")
    code, out, err = run("identify", "two.csv", "--fov", "10", "--size", "64x64",
                         "--sky", "random", "--output", "-", "--format", "json")
    assert code == 1, err
    assert '"input": "two.csv"' in out and "too_few_stars" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.csv"]


def test_an_output_named_dash_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(OutputError, match="standard output is not a file"):
        Writer().check("-", "--output")
    assert list(tmp_path.iterdir()) == []


def test_csv_with_astronomical_coordinates_is_one_line(tmp_path):
    # 1e300 is finite: it passed the CSV check and overflowed in the projection.
    path = tmp_path / "huge.csv"
    path.write_text("x,y,flux\n10,20,5\n1e300,1e300,4\n30,40,3\n")
    code, _, err = run("identify", path, "--fov", "10", "--size", "64x64", "--sky", "random")
    one_line_error(code, err, "huge.csv", "line 3", "1e+07 px")


@pytest.mark.parametrize("bad", [np.inf, np.nan, 1e300, -1e300])
def test_api_centroid_array_with_junk_is_a_value_error(bad):
    # Non-finite centroids were solved (RuntimeWarnings from numpy, then "no_match") where
    # the same rows in a CSV are refused.
    rows = np.array([[10.0, 20.0], [bad, 30.0], [40.0, 50.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="row 1"):
            startrack.solve(rows, fov_deg=10, size=(64, 64), sky="random")


def test_cache_help_states_the_real_default():
    # The help said "default 1024" after the cap became 2048.
    from startrack.io._cache import DEFAULT_CACHE_MAX_MB

    code, out, _ = run("cache", "--help")
    assert code == 0 and f"(default {DEFAULT_CACHE_MAX_MB})" in " ".join(out.split())


def test_fits_with_an_absurd_exposure_is_one_line(tmp_path):
    # EXPTIME = 1e300 s moved the observation time past erfa's range: 50 lines of traceback.
    from astropy.io import fits

    path = tmp_path / "exptime.fits"
    header = fits.Header([("DATE-OBS", "2019-07-29T20:47:26"), ("EXPTIME", 1e300)])
    fits.PrimaryHDU(np.full((16, 16), 100, np.uint16), header=header).writeto(path)
    code, _, err = run("identify", path, "--fov", "10")
    one_line_error(code, err, "exptime.fits", "EXPTIME", "out of range")


def test_csv_with_a_400_digit_number_is_one_line(tmp_path):
    # pandas raised OverflowError (not a ValueError) coercing it: a traceback.
    path = tmp_path / "bigint.csv"
    path.write_text("x,y\n" + "9" * 400 + ",2\n")
    code, _, err = run("identify", path, "--fov", "10", "--size", "64x64", "--sky", "random")
    one_line_error(code, err, "bigint.csv", "not a readable CSV")


@pytest.mark.parametrize("name", ["bad\nname.png", "tab\there.csv", "cr\rname.png"])
def test_a_file_name_with_control_characters_stays_one_line(tmp_path, name):
    # A newline in a name split the error in two lines; it is written escaped.
    path = tmp_path / name
    path.write_bytes(b"")
    code, _, err = run("identify", path, "--fov", "10", "--size", "64x64")
    one_line_error(code, err, repr(name)[1:-1])


def test_a_camera_file_of_another_format_says_it_is_read_as_json(tmp_path):
    path = tmp_path / "camera.yaml"
    path.write_text("width: 64\n")
    code, _, err = run("identify", tmp_path / "x.csv", "--camera", path)
    one_line_error(code, err, "camera.yaml", "not valid JSON")


@pytest.mark.parametrize(("first", "second"), [("--output", "--corr"), ("--output", "--annotate"),
                                               ("--wcs", "--annotate")])
def test_two_outputs_on_one_file_are_refused(tmp_path, first, second):
    # --output x --corr x exited 0: the second write replaced the first.
    frame = tmp_path / "frame.csv"
    frame.write_text("x,y\n10,20\n30,40\n")
    target = tmp_path / "both.out"
    code, _, err = run("identify", frame, "--fov", "10", "--size", "64x64", "--sky", "random",
                       first, target, second, target)
    one_line_error(code, err, "both.out", "is also")
    assert not target.exists()


def test_writer_lets_one_output_be_checked_twice(tmp_path):
    writer = Writer()
    target = tmp_path / "out.txt"
    assert writer.check(target, "--output") == writer.check(target, "--output")


@pytest.mark.parametrize("scale", [("1e-6", "1e-5", "arcsecperpix"), ("1e5", "1e6", "degwidth")])
def test_a_scale_range_outside_the_fov_range_is_refused(tmp_path, scale):
    # 1e-6 to 1e-5 arcsec/px (a 0.01" field) searched for 40 s before "no_match".
    frame = tmp_path / "frame.csv"
    frame.write_text("x,y\n10,20\n30,40\n50,60\n")
    low, high, units = scale
    code, _, err = run("identify", frame, "--size", "64x64", "--sky", "random", "--scale-low",
                       low, "--scale-high", high, "--scale-units", units)
    one_line_error(code, err, "--scale-low/--scale-high", "is outside [0.001, 179] deg")


def test_an_unwritable_cache_folder_is_said_once(tmp_path, monkeypatch):
    # STARTRACK_CACHE_DIR naming a file: every run rebuilt its databases (78 s) in silence.
    from startrack.errors import StartrackWarning
    from startrack.io import _cache as cache

    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("mine\n")
    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(not_a_folder))
    monkeypatch.setattr(cache, "_warned_unwritable", [])
    with pytest.warns(StartrackWarning, match="cannot be written") as seen:
        for k in range(3):
            assert cache.cached_arrays("t", {"k": k}, lambda: {"a": np.arange(3)})["a"][2] == 2
    assert len(seen) == 1 and str(not_a_folder) in str(seen[0].message)
    assert not_a_folder.read_text() == "mine\n"


def test_frames_dir_with_a_junk_truth_row_names_the_line(tmp_path):
    # "garbage,row" appended to truth.csv was taken for a frame: "row.json: cannot read".
    from startrack.io._sidecar import STARS_COLUMNS, TRUTH_COLUMNS

    (tmp_path / "truth.csv").write_text(",".join(TRUTH_COLUMNS) + "\n"
                                        "0,frame_0000.png,1,0,0,0,0,0,0\ngarbage,row\n")
    (tmp_path / "stars.csv").write_text(",".join(STARS_COLUMNS) + "\n0,1,2,3,4,5,0\n")
    code, _, err = run("compare", "--frames-dir", tmp_path, "--out", tmp_path / "cmp")
    one_line_error(code, err, "truth.csv: line 3", "must be finite numbers")
    assert not (tmp_path / "cmp").exists()


def test_api_folder_as_a_frame_says_so(tmp_path):
    # A folder without an extension was "unsupported image type '(none)'".
    folder = tmp_path / "frames"
    folder.mkdir()
    with pytest.raises(ValueError, match="is a directory, not an image or centroid CSV"):
        startrack.solve(folder, fov_deg=10)
