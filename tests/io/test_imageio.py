"""Frame reading and writing: round trips per format, and one-line errors for bad files."""

import re

import cv2
import numpy as np
import pytest
import tifffile

from startrack.errors import InputError
from startrack.io._images import read_image, write_fits, write_png16


@pytest.fixture()
def frame16():
    return np.random.default_rng(1).integers(0, 65536, (23, 37), dtype=np.uint16)


def test_png16_round_trip(tmp_path, frame16):
    path = tmp_path / "f.png"
    write_png16(path, frame16)
    back = read_image(path)
    assert back.dtype == np.uint16
    np.testing.assert_array_equal(back, frame16)
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]  # no temporary left behind


def test_png16_from_float_rounds_and_clips(tmp_path):
    image = np.array([[-5.0, 1.4], [1.6, 1e6]])
    write_png16(tmp_path / "f.png", image)
    np.testing.assert_array_equal(read_image(tmp_path / "f.png"), [[0, 1], [2, 65535]])


def test_png8_read(tmp_path):
    image = np.random.default_rng(2).integers(0, 256, (10, 12), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "f.png"), image)
    back = read_image(tmp_path / "f.png")
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, image)


def test_colour_png_becomes_grey(tmp_path):
    bgr = np.zeros((4, 5, 3), np.uint8)
    bgr[..., 2] = 200  # pure red in OpenCV's BGR order
    cv2.imwrite(str(tmp_path / "c.png"), bgr)
    back = read_image(tmp_path / "c.png")
    assert back.shape == (4, 5)
    assert np.all(back == round(0.299 * 200))


@pytest.mark.parametrize("compression", [None, "zlib"])
def test_tiff_round_trip(tmp_path, frame16, compression):
    path = tmp_path / "f.tiff"
    tifffile.imwrite(path, frame16, compression=compression)
    np.testing.assert_array_equal(read_image(path), frame16)


def test_float_tiff_round_trip(tmp_path):
    image = np.random.default_rng(3).normal(100, 5, (9, 11)).astype(np.float32)
    tifffile.imwrite(tmp_path / "f.tif", image)
    back = read_image(tmp_path / "f.tif")
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, image)


@pytest.mark.parametrize("dtype", [np.uint16, np.float32, np.int32])
def test_fits_round_trip(tmp_path, frame16, dtype):
    image = frame16.astype(dtype)
    path = tmp_path / "f.fits"
    write_fits(path, image, {"EXPTIME": 0.5})
    back = read_image(path)
    assert back.dtype == dtype
    assert back.dtype.byteorder in ("=", "|")
    np.testing.assert_array_equal(back, image)
    from astropy.io import fits

    assert fits.getheader(path)["EXPTIME"] == 0.5


def test_fits_cube_is_an_error(tmp_path):
    from astropy.io import fits

    fits.PrimaryHDU(np.zeros((3, 4, 5), np.float32)).writeto(tmp_path / "cube.fits")
    with pytest.raises(InputError, match=r"cube\.fits.*3-D"):
        read_image(tmp_path / "cube.fits")


def test_fits_degenerate_axis_is_squeezed(tmp_path):
    from astropy.io import fits

    fits.PrimaryHDU(np.ones((1, 4, 5), np.float32)).writeto(tmp_path / "one.fits")
    assert read_image(tmp_path / "one.fits").shape == (4, 5)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.png: no such file"):
        read_image(tmp_path / "nothere.png")


def test_text_file_named_png(tmp_path):
    path = tmp_path / "notes.png"
    path.write_text("this is not an image\n")
    with pytest.raises(InputError, match=r"notes\.png: not a readable PNG"):
        read_image(path)


@pytest.mark.parametrize("name", ["empty.png", "empty.tiff", "empty.fits"])
def test_empty_file(tmp_path, name):
    (tmp_path / name).write_bytes(b"")
    with pytest.raises(InputError, match=re.escape(name) + ": empty file"):
        read_image(tmp_path / name)


def test_garbage_fits(tmp_path):
    (tmp_path / "bad.fits").write_bytes(b"\x00garbage" * 50)
    with pytest.raises(InputError, match=r"bad\.fits"):
        read_image(tmp_path / "bad.fits")


def test_zero_size_array(tmp_path):
    from astropy.io import fits

    fits.PrimaryHDU(np.zeros((0, 5), np.float32)).writeto(tmp_path / "zero.fits")
    with pytest.raises(InputError, match=r"zero\.fits"):
        read_image(tmp_path / "zero.fits")
    with pytest.raises(InputError, match=r"z\.png.*2-D"):
        write_png16(tmp_path / "z.png", np.zeros((0, 3)))
    assert not (tmp_path / "z.png").exists()


def test_unsupported_extension(tmp_path):
    path = tmp_path / "frame.jp2x"
    path.write_bytes(b"1234")
    with pytest.raises(InputError, match=r"frame\.jp2x: unsupported image type"):
        read_image(path)


def test_write_3d_is_an_error(tmp_path):
    with pytest.raises(InputError, match=r"f\.fits"):
        write_fits(tmp_path / "f.fits", np.zeros((2, 3, 4)))
    assert list(tmp_path.iterdir()) == []


def test_tiff_stack_is_an_error(tmp_path):
    tifffile.imwrite(tmp_path / "stack.tiff", np.zeros((5, 4, 10), np.uint16))
    with pytest.raises(InputError, match=r"stack\.tiff.*stack \(5, 4, 10\)"):
        read_image(tmp_path / "stack.tiff")


def test_tiff_opencv_cannot_decode_falls_back_to_tifffile(tmp_path, frame16):
    path = tmp_path / "lzma.tiff"
    tifffile.imwrite(path, frame16, compression="lzma")
    np.testing.assert_array_equal(read_image(path), frame16)


def test_corrupt_tiff_is_an_error_without_console_noise(tmp_path, capfd, frame16):
    path = tmp_path / "cut.tiff"
    tifffile.imwrite(path, frame16)
    path.write_bytes(path.read_bytes()[:300])  # truncated mid-strip
    with pytest.raises(InputError, match=r"cut\.tiff"):
        read_image(path)
    assert capfd.readouterr().err == ""
