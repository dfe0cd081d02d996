"""The gaia sky: the GDR3 binary, proper motion to an epoch, and the default-sky policy."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.errors import InputError
from startrack.sky import GAIA_BELOW_FOV_DEG, SkySpec, default_sky_kind, load_sky, resolve_sky
from startrack.sky._gaia import read_gaia_bin

BARNARD_HIP = 87937  # Barnard's star: 10.3 arcsec/yr, in Hipparcos and in Gaia to G = 10


def _write(path, records, count=None):
    with open(path, "wb") as fh:
        fh.write(b"GDR3" + struct.pack("<I", 1) + struct.pack("<Q", len(records)
                                                              if count is None else count))
        for rec in records:
            fh.write(struct.pack("<qddfff", *rec))


def test_read_gaia_bin_reads_records(tmp_path):
    path = tmp_path / "g.bin"
    _write(path, [(123, 10.0, 20.0, 5.5, 0.0, 0.0), (-7, 11.0, -30.0, 1.0, 0.0, 0.0)])
    data = read_gaia_bin(path)
    assert data["id"].tolist() == [123, -7]
    assert data["dec"].tolist() == [20.0, -30.0]
    assert data["mag"][0] == pytest.approx(5.5)


@pytest.mark.parametrize("damage", ["magic", "count", "short"])
def test_read_gaia_bin_refuses_a_damaged_file(tmp_path, damage):
    path = tmp_path / "g.bin"
    _write(path, [(1, 1.0, 2.0, 3.0, 0.0, 0.0)], count=5 if damage == "count" else None)
    if damage == "magic":
        path.write_bytes(b"XXXX" + path.read_bytes()[4:])
    if damage == "short":
        path.write_bytes(b"GDR3")
    with pytest.raises(InputError, match=str(path)):
        read_gaia_bin(path)


def test_default_sky_is_gaia_for_narrow_or_unknown_fields_without_tycho2(tmp_path, monkeypatch):
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))  # no index file: no Tycho-2
    assert default_sky_kind(None) == "gaia"
    assert default_sky_kind(Camera.from_fov(1024, 1024, 1.0)) == "gaia"
    assert default_sky_kind(Camera.from_fov(1024, 1024, 3.0)) == "gaia"
    assert default_sky_kind(Camera.from_fov(1024, 768, 11.42)) == "hipparcos"
    assert GAIA_BELOW_FOV_DEG > 5.0
    assert SkySpec.from_dict({"kind": "gaia"}).kind == "gaia"


@pytest.fixture(scope="module")
def gaia():
    return load_sky(SkySpec(kind="gaia"))


def test_gaia_sky_ids_magnitudes_and_hipparcos_entries(gaia):
    assert len(gaia) > 400_000 and np.all(np.diff(gaia.mag) >= 0)
    assert gaia.mag.max() <= 10.0 + 1e-6
    assert np.any(gaia.ids < 0) and np.any(gaia.ids > 10**15)  # -HIP and Gaia source ids
    spec = resolve_sky(SkySpec(kind="gaia"), Camera.from_fov(1024, 1024, 2.0))
    assert spec.mag_limit == 10.0  # a 2 deg field needs every star the catalog has


def test_proper_motion_moves_barnards_star(gaia):
    later = load_sky(SkySpec(kind="gaia", epoch=2026.0))
    from startrack.sky._catalog import radec_to_vectors
    from startrack.sky._hipparcos import hipparcos_arrays, propagate

    hip = hipparcos_arrays()
    k = np.flatnonzero(hip["ids"] == BARNARD_HIP)
    ra, dec = propagate(hip["ra_deg"][k], hip["dec_deg"][k], hip["pm_ra"][k], hip["pm_dec"][k],
                        2016.0 - 1991.25)
    v = radec_to_vectors(ra, dec)[0]
    row = int(np.argmax(gaia.vectors @ v))  # the Gaia star at Barnard's J2016 place
    assert math.degrees(math.acos(min(1.0, float(gaia.vectors[row] @ v)))) * 3600 < 1.0
    moved = math.degrees(math.acos(min(1.0, float(gaia.vectors[row] @ later.vectors[row]))))
    assert moved * 3600 == pytest.approx(10.36 * 10.0, rel=0.05)  # 2016.0 -> 2026.0
