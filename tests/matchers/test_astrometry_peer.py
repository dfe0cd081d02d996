"""The astrometry peer (astrometry.net's solve-field) on a simulated 1 deg Tycho-2 frame,
and its one-line refusal when it is not installed."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.matchers import get_matcher
from startrack.sky import index_files, random_sky


def test_missing_index_files_give_the_install_hint(tmp_path, monkeypatch):
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))
    db = StarDatabase(random_sky(n_stars=200, seed=1), Camera.from_fov(640, 480, 10.0))
    with pytest.raises(InputError, match="apt-get install astrometry.net"):
        get_matcher("astrometry")(db).prepare()


installed = pytest.mark.skipif(shutil.which("solve-field") is None or not index_files(),
                               reason="astrometry.net or its Tycho-2 index not installed "
                                      "(make astrometry-ci)")


@installed
def test_peer_names_the_true_stars_of_a_one_degree_frame():
    from startrack.bench import Condition, make_frame
    from startrack.sky import SkySpec, load_sky
    from startrack.solver import Identifier

    camera = Camera.from_fov(640, 512, 1.0)
    catalog = load_sky(SkySpec(kind="tycho2", mag_limit=11.5), camera)
    frame = make_frame(catalog, camera, Condition(noise_px=0.2, false_stars=2), 3, 0)
    ident = Identifier(camera, catalog, "astrometry")
    sol = ident.identify(frame.obs)
    assert sol.solved
    truth = frame.truth_rows[sol.obs_index]
    assert len(truth) >= 6 and np.array_equal(truth, sol.cat_index)
    b, t = sol.rotation.apply([0, 0, 1.0]), frame.rotation.apply([0, 0, 1.0])
    assert np.degrees(np.arccos(min(1.0, b @ t))) * 3600 < 5.0
    assert 0.0 < sol.diagnostics.method_ms < 30_000  # the solve-field process's wall time


@installed
@pytest.mark.slow  # two interpreter starts and a render: about 30 s
def test_solve_field_solves_a_one_degree_frame(tmp_path):
    (tmp_path / "cam.json").write_text('{"width": 640, "height": 512, "fov_deg": 1.0}')

    def startrack(*args):
        return subprocess.run([sys.executable, "-m", "startrack", *args], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600)

    done = startrack("simulate", "--config", "narrow_gaia", "--camera", "cam.json", "--sky",
                     "tycho2", "--mag-limit", "11.5", "--attitude", "210.5,-40.2,75",
                     "--frames", "1", "--out", "out")
    assert done.returncode == 0, done.stderr
    done = startrack("identify", "out/frame_0000.png", "--method", "astrometry",
                     "--fov-tolerance", "0", "--format", "json")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["method"] == "astrometry"
    assert record["attitude"]["ra_deg"] == pytest.approx(210.5, abs=1e-3)
    assert record["attitude"]["dec_deg"] == pytest.approx(-40.2, abs=1e-3)
    truth = {round(s["x"]): s["catalog_id"] for s in record["stars"]}
    assert len(truth) >= 6


def test_wcs_attitude_recovers_the_rotation_of_a_written_header(tmp_path):
    from astropy.io import fits

    from startrack.attitude import angle_between_deg, from_radec_roll
    from startrack.matchers._astrometry import wcs_attitude
    from startrack.outputs import wcs_header

    camera = Camera.from_fov(1280, 1024, 20.0)
    for ra, dec, roll in ((10.0, 20.0, 30.0), (250.0, -70.0, 300.0), (0.5, 89.0, 0.0)):
        rotation = from_radec_roll(ra, dec, roll)
        path = tmp_path / "field.wcs"
        fits.PrimaryHDU(header=wcs_header(camera, rotation)).writeto(path, overwrite=True)
        assert angle_between_deg(wcs_attitude(path), rotation) * 3600 < 0.1
