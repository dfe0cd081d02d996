"""--sky FILE: the user's own catalog (CSV, FITS), each row checked, cached by content, and a
1 deg frame simulated and solved from one."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from waiting import CHILD_TIMEOUT_S

from startrack.errors import InputError
from startrack.io import cache_entries
from startrack.sky import SkySpec, load_sky, sky_spec
from startrack.sky._user_catalog import catalog_arrays, load_user_catalog, parse_catalog

GOOD = "ra,dec,mag,pm_ra,pm_dec,epoch,id\n10,20,5.5,100,-50,2016,7\n11,21,6.5,,,,8\n"


def _csv(tmp_path, text: str, name: str = "cat.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_csv_columns_defaults_and_epoch(tmp_path):
    path = _csv(tmp_path, GOOD)
    arrays = parse_catalog(path)
    assert arrays["ids"].tolist() == [7, 8]
    assert arrays["pm_ra"].tolist() == [100.0, 0.0] and arrays["epoch"].tolist() == [2016, 2000]
    at_2016 = load_user_catalog(path)
    assert at_2016.ids.tolist() == [7, 8]  # brightest first
    moved = load_user_catalog(path, epoch=2026.0)  # 10 years at 100 mas/yr east
    dra = (moved.ra_deg[0] - at_2016.ra_deg[0]) * np.cos(np.radians(20.0)) * 3.6e6
    assert dra == pytest.approx(1000.0, rel=1e-3)
    assert moved.ra_deg[1] == pytest.approx(11.0)  # no motion given: stays


def test_default_ids_are_row_numbers_and_other_columns_ignored(tmp_path):
    path = _csv(tmp_path, "RA, Dec, Mag, name\n1,2,3,a\n4,5,6,b\n")
    assert parse_catalog(path)["ids"].tolist() == [1, 2]


def test_fits_table(tmp_path):
    from astropy.table import Table

    path = tmp_path / "cat.fits"
    Table({"ra": [1.0, 2.0], "dec": [3.0, -4.0], "mag": [7.0, 6.0],
           "id": np.array([11, 12])}).write(path)
    catalog = load_sky(SkySpec(kind="file", path=str(path)))
    assert catalog.ids.tolist() == [12, 11] and catalog.dec_deg.tolist() == [-4.0, 3.0]


@pytest.mark.parametrize(("text", "message"), [
    ("ra,dec,mag\n1,2,3\n1,x,3\n", "row 2: dec 'x' is not a finite number"),
    ("ra,dec,mag\n1,2,3\n1,2,3\n1,95,3\n", "row 3: dec 95 is outside"),
    ("ra,dec,mag\n1,2,\n", "row 1: mag"),
    ("ra,dec,mag,id\n1,2,3,5\n1,2,3,5\n", "row 2: id 5 repeats"),
    ("ra,dec,mag,id\n1,2,3,5.5\n", "row 1: id '5.5' is not an integer"),
    ("ra,dec\n1,2\n", "missing column(s) mag"),
    ("ra,dec,mag\n", "no rows"),
])
def test_bad_rows_name_file_and_row(tmp_path, text, message):
    path = _csv(tmp_path, text)
    with pytest.raises(InputError) as err:
        parse_catalog(path)
    assert str(path) in str(err.value) and message in str(err.value)
    assert "\n" not in str(err.value)


def test_parquet_without_pyarrow_says_so(tmp_path):
    pytest.importorskip("pandas")
    try:
        import pyarrow  # noqa: F401
        pytest.skip("pyarrow installed: Parquet is read")
    except ImportError:
        pass
    path = tmp_path / "cat.parquet"
    path.write_bytes(b"PAR1")
    with pytest.raises(InputError, match="pyarrow"):
        parse_catalog(path)


def test_cached_by_content(tmp_path):
    path = _csv(tmp_path, GOOD)
    first = catalog_arrays(path)
    entries = {p.name for p, _, _ in cache_entries() if p.name.startswith("usersky")}
    copy = shutil.copy(path, tmp_path / "copy.csv")
    assert catalog_arrays(copy)["ids"].tolist() == first["ids"].tolist()
    assert {p.name for p, _, _ in cache_entries() if p.name.startswith("usersky")} == entries
    path.write_text(GOOD.replace("5.5", "4.5"))
    assert catalog_arrays(path)["mag"].min() == 4.5  # new content, parsed again


def test_sky_spec_of_a_path(tmp_path):
    path = _csv(tmp_path, GOOD)
    spec = sky_spec(str(path))
    assert spec.kind == "file" and spec.path == str(path.resolve())
    assert SkySpec.from_dict(spec.to_dict()) == spec
    assert load_sky(path).ids.tolist() == [7, 8]  # the API's load_sky takes the path too
    assert "path" not in SkySpec(kind="gaia").to_dict()
    with pytest.raises(InputError, match="neither"):
        sky_spec("nonsense")
    with pytest.raises(InputError, match="path"):
        SkySpec.from_dict({"kind": "file"})


def _startrack(*args, cwd):
    return subprocess.run([sys.executable, "-m", "startrack", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=CHILD_TIMEOUT_S)


def test_bad_catalog_row_on_the_command_line_exit_2(tmp_path):
    bad = _csv(tmp_path, "ra,dec,mag\n1,2,3\n1,2,bright\n", "bad.csv")
    done = _startrack("simulate", "--sky", bad, "--frames", "1", "--out", tmp_path / "o",
                      cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0
    assert "bad.csv: row 2: mag 'bright'" in done.stderr
    assert not (tmp_path / "o").exists()


def _patch_catalog(path, n: int = 3000, seed: int = 4) -> None:
    """A few thousand stars in a 3 x 3 deg patch about (150, 20), brighter ones rarer."""
    rng = np.random.default_rng(seed)
    ra = 150.0 + rng.uniform(-1.5, 1.5, n) / np.cos(np.radians(20.0))
    dec = 20.0 + rng.uniform(-1.5, 1.5, n)
    mag = 12.0 - rng.exponential(1.2, n).clip(0, 6)
    rows = "\n".join(f"{a:.7f},{d:.7f},{m:.3f}" for a, d, m in zip(ra, dec, mag, strict=True))
    path.write_text("ra,dec,mag\n" + rows + "\n")


def test_one_degree_frame_simulated_and_solved_from_a_catalog_file(tmp_path):
    catalog = tmp_path / "patch.csv"
    _patch_catalog(catalog)
    (tmp_path / "cam.json").write_text('{"width": 640, "height": 512, "fov_deg": 1.0}')
    done = _startrack("simulate", "--config", "narrow_gaia", "--camera", "cam.json",
                      "--sky", catalog, "--mag-limit", "12", "--attitude", "150.2,19.8,30",
                      "--frames", "1", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    side = json.loads((tmp_path / "out" / "frame_0000.json").read_text())
    assert side["sky"]["kind"] == "file" and side["sky"]["path"] == str(catalog)
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(tmp_path / "out" / "frame_0000.png", bare)
    done = _startrack("identify", bare / "frame_0000.png", "--sky", catalog, "--fov", "1.04",
                      "--format", "json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["attitude"]["ra_deg"] == pytest.approx(150.2, abs=2e-3)
    assert record["attitude"]["dec_deg"] == pytest.approx(19.8, abs=2e-3)
    assert len(record["stars"]) >= 6
    import startrack  # the API, on the frame with its sidecar (camera and sky from it)

    solved = startrack.solve(tmp_path / "out" / "frame_0000.png")
    assert solved.solved and solved.ra_deg == pytest.approx(150.2, abs=2e-3)
    assert solved.dec_deg == pytest.approx(19.8, abs=2e-3)
    assert startrack.solve(bare / "frame_0000.png", fov_deg=1.0, sky=catalog).solved
