"""Issue 10, the inputs: malformed, oversized (pixels, rows, catalog pairs) or nearly empty,
each one stderr line and exit 2, or the right answer."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.cli import test_reliability
from tests.cli.test_reliability import cli, one_error

sim = test_reliability.sim  # the frames fixture, shared


# --- inputs: malformed, too large, too few stars -----------------------------------------

@pytest.mark.parametrize("content, word", [
    ("x,y\n1,2\n3,oops\n", "line 3"),
    ("a,b\n1,2\n", "missing column 'x'"),
    ("x,y,flux\n1,2,inf\n", "line 2"),
    ("", "not a readable CSV"),
])
def test_malformed_csv_is_one_line(sim, tmp_path, content, word):
    _, cam, _, _ = sim
    bad = tmp_path / "bad.csv"
    bad.write_text(content)
    one_error(cli("identify", bad, "--camera", cam), "bad.csv", word)


def test_malformed_image_is_one_line(sim, tmp_path):
    _, cam, _, _ = sim
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 10)
    one_error(cli("identify", bad, "--camera", cam), "bad.png")


def test_too_few_stars_is_not_solved(sim, tmp_path):
    _, cam, _, _ = sim
    few = tmp_path / "few.csv"
    few.write_text("x,y\n10,10\n100,120\n")
    result = cli("identify", few, "--camera", cam, "--sky", "random", "--format", "json")
    assert result.returncode == 1
    assert json.loads(result.stdout)["reason"] == "too_few_stars"


def test_a_batch_answers_every_input(sim, tmp_path):
    _, _, png, _ = sim
    out = tmp_path / "out.jsonl"
    result = cli("identify", png, tmp_path / "missing.png", png, "--format", "json",
                 "--output", out)
    assert result.returncode == 2
    assert [r["status"] for r in map(json.loads, out.read_text().splitlines())] == \
        ["solved", "error", "solved"]


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr
            + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr)))


def test_a_huge_image_is_refused_from_its_header(tmp_path):
    huge = tmp_path / "huge.png"
    huge.write_bytes(_png_header(20000, 20000))  # 400 Mpx claimed: never decoded
    one_error(cli("identify", huge, "--fov", "10"), "huge.png", "20000 x 20000",
              "STARTRACK_MAX_IMAGE_PIXELS")


@pytest.mark.parametrize("suffix", [".png", ".tiff", ".fits"])
def test_the_pixel_limit_holds_for_each_format(tmp_path, suffix):
    from startrack.io._images import write_fits, write_png16

    image = np.zeros((120, 100), np.uint16)
    path = tmp_path / f"big{suffix}"
    if suffix == ".tiff":
        import tifffile

        tifffile.imwrite(path, image)
    else:
        (write_fits if suffix == ".fits" else write_png16)(path, image)
    result = cli("identify", path, "--fov", "10", env={"STARTRACK_MAX_IMAGE_PIXELS": "10000"})
    one_error(result, path.name, "12,000 pixels")


def test_a_200k_row_csv_keeps_its_brightest_rows_and_says_so(sim, tmp_path):
    _, cam, _, csv_path = sim
    rng = np.random.default_rng(3)
    rows = csv_path.read_text().splitlines()[1:]
    faint = rng.uniform(0, 255, (200_000 - len(rows), 2))
    text = "x,y,flux\n" + "\n".join(rows) + "\n" + "".join(
        f"{x:.2f},{y:.2f},0.5\n" for x, y in faint)
    big = tmp_path / "big.csv"
    big.write_text(text)
    result = cli("identify", big, "--camera", cam, "--sky", "random", "--format", "json")
    assert "kept the brightest 1000 of 200000 centroids" in one_error(
        result, "big.csv", code=result.returncode)
    assert result.returncode in (0, 1) and json.loads(result.stdout)["status"] != "error"


def test_a_magnitude_limit_beyond_the_pair_budget_names_the_option(sim):
    _, cam, _, csv_path = sim
    result = cli("identify", csv_path, "--camera", cam, "--sky", "hipparcos",
                 "--mag-limit", "20", "--fov-tolerance", "0")  # a pair-table method
    one_error(result, "--mag-limit", "STARTRACK_MAX_PAIRS")


def test_the_api_refuses_a_camera_and_a_fov_together():
    import startrack
    from startrack.camera import Camera
    from startrack.errors import InputError

    with pytest.raises(InputError, match="not both"):
        startrack.Solver(fov_deg=10.0, camera=Camera.from_fov(256, 256, 17.5))
