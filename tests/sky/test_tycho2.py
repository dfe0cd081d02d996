"""The tycho2 sky: astrometry.net index files read (a written one, and the installed ones),
deduplicated, their ids, and the default-sky rule that picks it."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.errors import InputError
from startrack.sky import SkySpec, deeper_sky_note, default_sky_kind, load_sky
from startrack.sky._catalog import radec_to_vectors
from startrack.sky._tycho2 import (
    TYCHO_ID_BASE,
    index_files,
    parse_index_files,
    position_ids,
    read_index_stars,
    tycho2_arrays,
)

SCALE = 2.0**31 - 1  # tree units per data unit over [-1, 1], as the Debian files have


def write_index(path, ra_deg, dec_deg, mag, *, scale=SCALE, endian="04:03:02:01",
                trim=0) -> None:
    """A minimal index file as astrometry.net writes one: the star tree's data (u32
    triples, as raw bytes), its range table and the MAG_VT tag-along table (``scale``,
    ``endian`` and ``trim``, bytes cut off each star's data, make a damaged one)."""
    from astropy.io import fits

    v = radec_to_vectors(np.asarray(ra_deg), np.asarray(dec_deg))
    codes = np.round((v + 1.0) * SCALE).astype("<u4")
    box = np.array([-1, -1, -1, 1, 1, 1, scale], "<f8")

    def raw(name, data, width):  # bytes columns (the Debian files say 'A': astropy pads those)
        col = fits.Column(name=name, format=f"{width}B",
                          array=np.frombuffer(data.tobytes(), np.uint8).reshape(-1, width))
        return fits.BinTableHDU.from_columns([col])

    primary = fits.PrimaryHDU()
    primary.header["ENDIAN"] = endian
    mags = fits.BinTableHDU.from_columns([fits.Column(name="MAG_VT", format="E",
                                                      array=np.asarray(mag, "f4"))])
    fits.HDUList([primary, raw("kdtree_range_stars", box, 8),
                  raw("kdtree_data_stars", codes.view(np.uint8).reshape(-1, 12)[:, trim:],
                      12 - trim), mags]).writeto(path)


def test_reader_recovers_positions_and_magnitudes(tmp_path):
    rng = np.random.default_rng(5)
    ra, dec = rng.uniform(0, 360, 200), np.degrees(np.arcsin(rng.uniform(-1, 1, 200)))
    mag = rng.uniform(2, 12, 200).round(3)
    path = tmp_path / "index-tycho2-99.fits"
    write_index(path, ra, dec, mag)
    vectors, vt = read_index_stars(path)
    sep = np.degrees(np.arccos(np.clip(np.sum(vectors * radec_to_vectors(ra, dec), 1), -1, 1)))
    assert sep.max() * 3600 < 0.01
    np.testing.assert_allclose(vt, mag, atol=1e-3)


@pytest.mark.parametrize(("damage", "said"), [
    ({"scale": 0.0}, "scale"), ({"scale": float("nan")}, "scale"),
    ({"endian": "12:34:56:78"}, "ENDIAN"), ({"trim": 5}, "cannot read the index file"),
])
def test_a_damaged_index_file_is_one_line_naming_it(tmp_path, damage, said):
    path = tmp_path / "index-tycho2-98.fits"
    write_index(path, [10.0, 20.0, 30.0], [0.0, 5.0, 10.0], [5.0, 6.0, 7.0], **damage)
    with pytest.raises(InputError, match=said) as caught:
        read_index_stars(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_union_of_files_is_deduplicated_with_stable_ids(tmp_path, monkeypatch):
    ra, dec, mag = np.array([10.0, 20.0, 30.0]), np.array([5.0, -5.0, 60.0]), [6.0, 7.0, 8.0]
    write_index(tmp_path / "index-tycho2-08.fits", ra, dec, mag)
    # the second file repeats the first two stars (0.2" off) and adds one
    write_index(tmp_path / "index-tycho2-09.fits", [10.0, 20.0 + 0.2 / 3600, 40.0],
                [5.0, -5.0, -70.0], [6.0, 7.0, 9.0])
    files = sorted(tmp_path.glob("*.fits"))
    arrays = parse_index_files(files)
    assert len(arrays["ids"]) == 4
    assert sorted(arrays["mag"].round(3)) == [6.0, 7.0, 8.0, 9.0]
    alone = parse_index_files(files[:1])
    common = np.isin(arrays["ids"], alone["ids"])  # the same star, the same id
    assert np.count_nonzero(common) == 3
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))
    assert index_files() == files
    assert len(tycho2_arrays()["ids"]) == 4  # built once, then from the cache
    assert len(tycho2_arrays()["ids"]) == 4


def test_position_ids_encode_tenths_of_arcsec():
    ids = position_ids(np.array([0.0, 359.99999999, 180.0]), np.array([-90.0, 0.0, 90.0]))
    assert ids[0] == TYCHO_ID_BASE and ids[1] == TYCHO_ID_BASE + 90 * 36000
    assert ids[2] == TYCHO_ID_BASE + 180 * 36000 * 6_480_001 + 180 * 36000


def test_no_index_file_names_the_package(tmp_path, monkeypatch):
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))
    with pytest.raises(InputError, match="astrometry-data-tycho2-07-littleendian"):
        load_sky(SkySpec(kind="tycho2"))
    note = deeper_sky_note(Camera.from_fov(1280, 1024, 1.0), "gaia")
    assert "astrometry-data-tycho2-07-littleendian" in note and "\n" not in note
    assert deeper_sky_note(Camera.from_fov(1280, 1024, 5.0), "gaia") is None


def test_default_sky_takes_tycho2_where_gaia_is_too_shallow(tmp_path, monkeypatch):
    (tmp_path / "index-tycho2-07.fits").write_bytes(b"")
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))
    assert default_sky_kind(None) == "tycho2"
    assert default_sky_kind(Camera.from_fov(1280, 1024, 1.0)) == "tycho2"
    assert default_sky_kind(Camera.from_fov(640, 480, 1.5)) == "tycho2"
    assert default_sky_kind(Camera.from_fov(2048, 1536, 3.0)) == "gaia"
    assert default_sky_kind(Camera.from_fov(1024, 768, 11.4)) == "hipparcos"
    assert deeper_sky_note(Camera.from_fov(1280, 1024, 1.0), "gaia") is None


installed = pytest.mark.skipif(not index_files(), reason="no Tycho-2 index files installed "
                               "(make astrometry-ci)")


@installed
def test_installed_index_files_give_a_deep_sky_with_hip_numbers():
    catalog = load_sky(SkySpec(kind="tycho2"))
    assert len(catalog) > 700_000 and len(np.unique(catalog.ids)) == len(catalog)
    assert np.all(np.diff(catalog.mag) >= 0) and catalog.mag.max() > 11.0
    hip1 = radec_to_vectors(0.00091185, 1.08901332)  # HIP 1 (V = 9.1; 5 mas/yr)
    row = int(np.argmax(catalog.vectors @ hip1))
    assert np.degrees(np.arccos(min(1.0, catalog.vectors[row] @ hip1))) * 3600 < 1.0
    assert catalog.ids[row] == 1  # a Hipparcos star keeps its HIP number
    assert np.count_nonzero(catalog.ids >= TYCHO_ID_BASE) > 0.9 * len(catalog)


def test_blind_split_is_where_the_default_sky_turns_to_tycho2(tmp_path, monkeypatch):
    from startrack.sky._default import gaia_min_fov, search_sky_kind

    (tmp_path / "index-tycho2-07.fits").write_bytes(b"")
    monkeypatch.setenv("STARTRACK_INDEX_DIR", str(tmp_path))
    for size in ((1024, 768), (640, 480), (3000, 2000)):
        split = gaia_min_fov(size)
        assert 1.0 < split < 3.0
        above, below = (Camera.from_fov(*size, split * f) for f in (1.01, 0.99))
        assert default_sky_kind(above) == search_sky_kind(above) == "gaia"
        assert default_sky_kind(below) == search_sky_kind(below) == "tycho2"
