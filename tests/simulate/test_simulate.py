"""`startrack simulate`: outputs, truth, reproducibility, presets and bad input."""

import csv
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from repo_paths import ROOT
from waiting import CHILD_TIMEOUT_S

from startrack.attitude import from_radec_roll, to_radec_roll
from startrack.cli import main
from startrack.errors import InputError
from startrack.io import read_image, read_sidecar, sidecar_path_for
from startrack.simulate._config import DEFAULT_CONFIG, config_from_dict, load_config
from startrack.sky import load_sky

CONFIGS = ROOT / "configs"
SMALL_CAMERA = '{"width": 320, "height": 240, "fov_deg": 30.0}'


def run(args, tmp_path):
    cam = tmp_path / "small.json"
    cam.write_text(SMALL_CAMERA)
    result = CliRunner().invoke(main, ["simulate", "--camera", str(cam), *args])
    assert result.exit_code == 0, result.output
    return result


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_default_run_writes_frames_sidecars_and_truth(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["simulate"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "out" / "simulate"
    assert "out/simulate" in result.output
    pngs = sorted(out.glob("frame_*.png"))
    assert [p.name for p in pngs] == [f"frame_{i:04d}.png" for i in range(3)]
    image = read_image(pngs[0])
    assert image.shape == (1024, 1024) and image.dtype == np.uint16
    truth = read_csv(out / "truth.csv")
    assert list(truth[0]) == ["frame", "file", "qw", "qx", "qy", "qz", "ra_deg", "dec_deg",
                              "roll_deg"]
    stars = read_csv(out / "stars.csv")
    assert list(stars[0]) == ["frame", "x", "y", "flux", "magnitude", "catalog_id",
                              "is_false"]
    assert {int(r["frame"]) for r in stars} == {0, 1, 2}

    # The sidecar alone rebuilds the camera, the sky and the truth, and they put every
    # listed star where stars.csv says.
    camera, spec, rotation = read_sidecar(sidecar_path_for(pngs[1]))
    assert (camera.width, camera.height) == (1024, 1024)
    q = [float(truth[1][k]) for k in ("qw", "qx", "qy", "qz")]
    np.testing.assert_allclose(rotation.as_quat(scalar_first=True) * np.sign(q[0]), q)
    catalog = load_sky(spec, camera)
    frame1 = [r for r in stars if r["frame"] == "1" and r["is_false"] == "0"]
    assert len(frame1) >= 3
    rows = catalog.index_of(np.array([int(r["catalog_id"]) for r in frame1]))
    x, y, _ = camera.vector_to_pixel(rotation.inv().apply(catalog.vectors[rows]))
    np.testing.assert_allclose(x, [float(r["x"]) for r in frame1], atol=1e-6)
    np.testing.assert_allclose(y, [float(r["y"]) for r in frame1], atol=1e-6)


def test_same_seed_same_files_and_frames_are_independent(tmp_path):
    a, b, c, d = (tmp_path / n for n in "abcd")
    common = ["--false-stars", "2", "--mag-noise", "0.1", "--missing", "0.1"]
    run(["--frames", "2", "--seed", "5", "--out", str(a), *common], tmp_path)
    run(["--frames", "2", "--seed", "5", "--out", str(b), *common], tmp_path)
    run(["--frames", "3", "--seed", "5", "--out", str(c), *common], tmp_path)
    run(["--frames", "2", "--seed", "6", "--out", str(d), *common], tmp_path)
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert (a / "frame_0001.png").read_bytes() == (c / "frame_0001.png").read_bytes()
    assert (a / "frame_0000.png").read_bytes() != (d / "frame_0000.png").read_bytes()
    assert sum(r["is_false"] == "1" for r in read_csv(a / "stars.csv")) == 4


def test_fixed_attitude_and_fits_with_wcs(tmp_path):
    from astropy.io import fits
    from astropy.wcs import WCS

    out = tmp_path / "o"
    run(["--frames", "2", "--attitude", "250.5,-33.25,120", "--fits", "--out", str(out)],
        tmp_path)
    for row in read_csv(out / "truth.csv"):
        ra, dec, roll = (float(row[k]) for k in ("ra_deg", "dec_deg", "roll_deg"))
        assert (ra, dec, roll) == pytest.approx((250.5, -33.25, 120.0), abs=1e-9)
    _, _, rotation = read_sidecar(out / "frame_0001.json")
    assert to_radec_roll(rotation) == pytest.approx((250.5, -33.25, 120.0), abs=1e-9)
    np.testing.assert_array_equal(read_image(out / "frame_0000.fits"),
                                  read_image(out / "frame_0000.png"))
    header = fits.getheader(out / "frame_0000.fits")
    centre = WCS(header).all_pix2world([[160.5, 120.5]], 1)[0]  # pixel (159.5, 119.5)
    assert centre == pytest.approx([250.5, -33.25], abs=1e-9)
    assert to_radec_roll(from_radec_roll(*centre, 120.0))[:2] == pytest.approx(tuple(centre))


def test_presets_load_and_default_is_paper2011():
    configs = {p.stem: load_config(p) for p in CONFIGS.glob("*.toml")}
    assert {"paper2011", "radial_triangles", "realsky"} <= set(configs)
    assert config_from_dict(DEFAULT_CONFIG) == configs["paper2011"]
    radial = configs["radial_triangles"].camera
    assert (radial.width, radial.fov_deg) == (4096, pytest.approx(4.0, abs=1e-5))
    real = configs["realsky"]
    assert (real.camera.width, real.camera.height) == (1024, 768)
    assert real.sky.kind == "hipparcos" and real.sky.epoch == pytest.approx(2019.6)


@pytest.mark.parametrize("text,match", [
    ("[camera]\nwidth = 10\nheight = 10\nfov_deg = 5\nzoom = 2\n", r"\[camera\].*zoom"),
    ("[lens]\nf = 3\n", "lens"),
    ("[sky]\nkind = 'random'\nstars = 10\n", r"\[sky\].*stars"),
    ("[sensor]\ngain = -1\n", r"\[sensor\].*gain"),
    ("[frames]\nmissing = 2.0\n", r"\[frames\].*missing"),
    ("[frames\n", "not valid TOML"),
])
def test_bad_config_is_input_error_naming_the_file(tmp_path, text, match):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=f"bad.toml.*{match}"):
        load_config(path)


BAD_OPTIONS = [
    ["--frames", "-1"],
    ["--attitude", "1,2"],
    ["--rate", "1,x,3"],
    ["--missing", "1.5"],
    ["--config", "{bad_config}"],
    ["--camera", "{missing_camera}"],
]


def _bad_args(tmp_path, args):
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera]\nwidth = 64\nheight = 64\nfov_deg = 5\nshutter = 1\n")
    return [a.format(bad_config=bad, missing_camera=tmp_path / "none.json") for a in args]


@pytest.mark.parametrize("args", BAD_OPTIONS)
def test_bad_options_exit_2_with_one_line_and_no_output(tmp_path, args):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["simulate", "--out", str(out),
                                       *_bad_args(tmp_path, args)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("startrack: error"), result.stderr
    assert not out.exists()


@pytest.mark.parametrize("args", [BAD_OPTIONS[0], BAD_OPTIONS[5]])
def test_bad_options_through_the_real_entry_point(tmp_path, args):
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "startrack", "simulate", "--out", str(out),
                           *_bad_args(tmp_path, args)], capture_output=True, text=True,
                          timeout=CHILD_TIMEOUT_S)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert not out.exists()
