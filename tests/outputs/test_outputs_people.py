"""identify --annotate, --wcs and --corr on the real-sky test frame and a batch; -q/-v;
the WCS writer's SIP hook; the star-name list and the stretch."""

import csv
import json

import cv2
import numpy as np
import pytest
from astropy.coordinates import SkyCoord
from astropy.io import fits
from astropy.wcs import WCS
from click.testing import CliRunner
from repo_paths import DATA, ROOT

from startrack.attitude import from_radec_roll
from startrack.camera import Camera
from startrack.cli import main
from startrack.outputs._annotate import (
    MARGIN_LEFT_PX,
    MARGIN_TOP_PX,
    _nice_magnification,
    star_names,
    stretch,
    write_annotated,
)
from startrack.outputs._annotate_sky import compass
from startrack.outputs._corr import CORR_COLUMNS
from startrack.outputs._labels import CIRCLE_RADIUS_PX, place_labels
from startrack.outputs._wcs import SipTerms, fit_sip, sip_order_for, wcs_header

FRAME = DATA / "realsky_azi45.png"
REAL = ["--fov", "11.42", "--sky", "hipparcos", "--epoch", "2019.6"]


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    out = tmp_path_factory.mktemp("real")
    args = ["identify", str(FRAME), *REAL, "--format", "json", "--annotate",
            str(out / "a.png"), "--wcs", str(out / "a.wcs"), "--corr", str(out / "a.csv")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    return out, json.loads(result.stdout.splitlines()[0])


def test_wcs_maps_every_identified_star_to_its_catalog_position(real):
    out, record = real
    header = fits.getheader(out / "a.wcs")
    assert header["CTYPE1"].startswith("RA---TAN") and header["CREATOR"].startswith("startrack")
    assert header["IMAGEW"] == 1024 and header["IMAGEH"] == 768
    w = WCS(header)
    stars = record["stars"]
    assert len(stars) >= 30
    x = np.array([s["x"] for s in stars])
    y = np.array([s["y"] for s in stars])
    ra, dec = w.all_pix2world(x, y, 0)  # our pixels as they are (origin 0)
    got = SkyCoord(ra, dec, unit="deg")
    want = SkyCoord([s["ra_deg"] for s in stars], [s["dec_deg"] for s in stars], unit="deg")
    assert got.separation(want).arcsec.max() < 10.0
    # FITS is 1-based: origin 1 takes (x + 1, y + 1) to the same place
    ra1, dec1 = w.all_pix2world(x + 1, y + 1, 1)
    assert np.allclose(ra1, ra) and np.allclose(dec1, dec)


def test_annotated_png_shows_the_stars_and_the_caption(real):
    out, record = real
    image = cv2.imread(str(out / "a.png"), cv2.IMREAD_COLOR)
    assert image.shape[1] > 1024 and image.shape[0] > 768  # frame plus margins and caption
    top, left = MARGIN_TOP_PX, MARGIN_LEFT_PX
    frame = image[top:top + 768, left:left + 1024]
    green = (frame[..., 1] > 200) & (frame[..., 2] < 120) & (frame[..., 0] < 120)
    assert green.sum() > 25 * len(record["stars"])  # a circle per identified star
    assert frame.mean() > 2  # the stretch shows something, not a black frame
    assert image[top + 768:].max() > 200  # caption text
    # the RA/Dec grid (blue dashes) crosses the frame, and the compass (yellow) stands
    # in the right margin
    b, g, r = frame[..., 0].astype(int), frame[..., 1].astype(int), frame[..., 2].astype(int)
    blue = (b > 90) & (b > r + 40) & (b > g + 15)
    assert blue.sum() > 2000
    margin = image[:top + 768, left + 1024:]
    yellow = (margin[..., 2] > 200) & (margin[..., 1] > 180) & (margin[..., 0] < 140)
    assert yellow.sum() > 50


def test_compass_points_north_and_east_on_the_solved_wcs():
    camera = Camera.from_fov(640, 480, 10.0)
    for roll in (0.0, 37.0, 200.0):
        w = WCS(wcs_header(camera, from_radec_roll(150.0, 40.0, roll)))
        arrows = compass(w, 320.0, 240.0, 30.0)
        ra0, dec0 = w.all_pix2world([320.0], [240.0], 0)
        ra_n, dec_n = w.all_pix2world([320.0 + arrows["N"][0]], [240.0 + arrows["N"][1]], 0)
        ra_e, dec_e = w.all_pix2world([320.0 + arrows["E"][0]], [240.0 + arrows["E"][1]], 0)
        assert dec_n[0] > dec0[0] and abs(ra_n[0] - ra0[0]) < 0.01
        assert ra_e[0] > ra0[0] and abs(dec_e[0] - dec0[0]) < 0.01
        assert np.hypot(*arrows["N"]) == pytest.approx(30.0)


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def test_labels_in_a_crowd_never_overlap_each_other_a_circle_or_the_edge():
    rng = np.random.default_rng(11)
    x, y = rng.uniform(0, 400, 50), rng.uniform(0, 300, 50)
    boxes = place_labels(x, y, [(56.0, 10.0)] * 50, 400, 300)
    placed = [b for b in boxes if b is not None]
    assert boxes[0] is not None and 25 < len(placed) < 50  # crowded: some left out
    for i, a in enumerate(placed):
        assert a[0] >= 0 and a[2] <= 400 and a[1] >= 0 and a[3] <= 300
        assert not any(_overlap(a, b) for b in placed[i + 1:])
        nx, ny = np.clip(x, a[0], a[2]) - x, np.clip(y, a[1], a[3]) - y
        assert (np.hypot(nx, ny) >= CIRCLE_RADIUS_PX).all()
    # alone, a star near the right edge is labelled on its left, one near the top below
    right, top = place_labels([295.0, 150.0], [100.0, 3.0], [(56.0, 10.0)] * 2, 300, 200)
    assert right[2] < 295.0 and top[1] > 3.0


def test_annotated_real_frame_labels_do_not_overlap_and_the_grid_is_labelled(tmp_path,
                                                                             monkeypatch):
    from astropy.visualization.wcsaxes.ticklabels import TickLabels

    import startrack

    grid: dict[str, int] = {}  # the coordinate labels WCSAxes drew, per edge
    draw = TickLabels.draw

    def counting(self, renderer, *args, **kwargs):
        draw(self, renderer, *args, **kwargs)
        for side, drawn in self._axis_bboxes.items():  # astropy drops overlapping ones
            grid[side] = max(grid.get(side, 0), len(drawn))

    monkeypatch.setattr(TickLabels, "draw", counting)
    result = startrack.solve(FRAME, fov_deg=11.42, sky="hipparcos", epoch=2019.6)
    drawn = write_annotated(result.frame, tmp_path / "a.png")
    boxes = drawn["labels"]
    assert len(boxes) + drawn["left_out"] == len(result.stars)
    assert len(boxes) >= 0.9 * len(result.stars)  # nearly every star keeps its label
    for i, a in enumerate(boxes):
        assert not any(_overlap(a, b) for b in boxes[i + 1:]), a
    # the grid labels both coordinates several times (it carried 2 RA and 3 Dec labels)
    assert grid["b"] >= 4 and grid["l"] >= 4  # RA along the bottom, Dec along the left


def test_corr_has_a_row_per_identified_star_with_units_in_plain_names(real):
    out, record = real
    with open(out / "a.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == CORR_COLUMNS
    assert all('"' not in c and "'" not in c for c in CORR_COLUMNS)
    assert len(rows) == len(record["stars"])
    for row, star in zip(rows, record["stars"], strict=True):
        assert int(row["catalog_id"]) == star["catalog_id"]
        assert float(row["residual_arcsec"]) == pytest.approx(star["residual_arcsec"])
        assert float(row["flux"]) > 0 and float(row["catalog_mag"]) < 9
        resid_px = np.hypot(float(row["residual_x_px"]), float(row["residual_y_px"]))
        assert resid_px * 11.42 * 3600 / 1024 == pytest.approx(star["residual_arcsec"],
                                                               rel=0.05, abs=0.5)


def test_batch_writes_one_file_per_input_into_folders(tmp_path):
    frames = []
    for name in ("one", "two"):
        frames.append(tmp_path / f"{name}.png")
        frames[-1].write_bytes(FRAME.read_bytes())
    result = CliRunner().invoke(main, ["identify", *map(str, frames), *REAL, "-v",
                                       "--annotate", str(tmp_path / "ann"),
                                       "--wcs", str(tmp_path / "wcs")])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "ann").iterdir()) == ["one.png", "two.png"]
    assert sorted(p.name for p in (tmp_path / "wcs").iterdir()) == ["one.wcs", "two.wcs"]
    assert "one.png: solved" in result.stderr and "wrote" in result.stderr


def test_annotate_named_like_a_file_with_several_inputs_writes_files_beside_it(tmp_path):
    frames = []
    for name in ("one", "two"):
        frames.append(tmp_path / f"{name}.png")
        frames[-1].write_bytes(FRAME.read_bytes())
    (tmp_path / "out").mkdir()
    result = CliRunner().invoke(main, ["identify", *map(str, frames), *REAL, "--annotate",
                                       str(tmp_path / "out" / "ann.png")])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["ann_one.png",
                                                                    "ann_two.png"]
    # without -v one line names what was written
    wrote = [line for line in result.stderr.splitlines() if line.startswith("wrote ")]
    assert wrote == [f"wrote {tmp_path / 'out' / 'ann_one.png'}, "
                     f"{tmp_path / 'out' / 'ann_two.png'}"]


def test_identify_says_what_it_wrote(real, tmp_path):
    result = CliRunner().invoke(main, ["identify", str(FRAME), *REAL, "--annotate",
                                       str(tmp_path / "x.png")])
    assert result.exit_code == 0
    assert f"wrote {tmp_path / 'x.png'}" in result.stderr.splitlines()


def test_quiet_prints_nothing_on_stderr_and_bad_target_is_exit_2(tmp_path):
    result = CliRunner().invoke(main, ["identify", str(FRAME), *REAL, "-q"])
    assert result.exit_code == 0 and result.stderr == ""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = CliRunner().invoke(main, ["identify", str(FRAME), str(FRAME), *REAL,
                                       "--annotate", str(blocker)])
    assert result.exit_code == 2 and "names a folder" in result.stderr


def test_sip_hook_and_fit():
    from startrack.attitude import from_radec_roll

    cam = Camera.from_fov(640, 480, 10.0)
    rot = from_radec_roll(40.0, -20.0, 30.0)
    plain = wcs_header(cam, rot)
    assert plain["CTYPE1"] == "RA---TAN" and "A_ORDER" not in plain
    a = np.zeros((3, 3))
    a[2, 0] = 1e-6
    sipped = WCS(wcs_header(cam, rot, sip=SipTerms(2, a, np.zeros((3, 3)))))
    assert sipped.sip is not None
    ra0, _ = WCS(plain).all_pix2world([600.0], [240.0], 0)
    ra1, _ = sipped.all_pix2world([600.0], [240.0], 0)
    assert abs(ra1 - ra0)[0] > 1e-6  # the SIP terms act
    # A fit to exact pinhole stars finds the pinhole: no distortion, same CD.
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 639, 60), rng.uniform(0, 479, 60)
    vectors = rot.apply(cam.pixel_to_vector(x, y))
    cd, sip = fit_sip(cam, rot, x, y, vectors, sip_order_for(60))
    assert np.allclose(cd, WCS(plain).wcs.get_pc() * WCS(plain).wcs.cdelt[:, None],
                       rtol=1e-6, atol=1e-12)
    assert np.abs(sip.a).max() < 1e-9 and np.abs(sip.b).max() < 1e-9
    assert sip_order_for(5) == 0


def test_star_names_are_the_iau_ones():
    names = star_names()
    assert names[32349] == "Sirius" and names[71683] == "Rigil Kentaurus"
    assert names[746] == "Caph" and len(names) > 400
    top = ROOT / "data" / "iau_star_names.csv"
    assert top.is_file()


def test_stretch_shows_a_faint_star_over_a_sloped_background():
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:200, 0:300]
    img = 1000 + 2.0 * xx + rng.normal(0, 10, (200, 300))
    img[100, 150] += 80  # eight noise levels
    out = stretch(img.astype(np.uint16))
    assert out.min() >= 0 and out.max() <= 1
    assert out[100, 150] > 0.3 and np.median(out) < 0.1
    assert _nice_magnification(0.5, 40) == 50 and _nice_magnification(0, 40) == 1


def test_unsolved_centroid_list_is_annotated_but_has_no_wcs(tmp_path):
    rng = np.random.default_rng(5)
    path = tmp_path / "random.csv"
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["x", "y", "flux"])
        for x, y, f in zip(rng.uniform(0, 1023, 12), rng.uniform(0, 767, 12),
                           rng.uniform(1, 100, 12), strict=True):
            writer.writerow([x, y, f])
    result = CliRunner().invoke(main, ["identify", str(path), *REAL, "--size", "1024x768",
                                       "--annotate", str(tmp_path / "r.png"), "--wcs",
                                       str(tmp_path / "r.wcs"), "--corr",
                                       str(tmp_path / "r.corr.csv")])
    assert result.exit_code == 1, result.output
    assert (tmp_path / "r.png").is_file() and not (tmp_path / "r.wcs").exists()
    lines = (tmp_path / "r.corr.csv").read_text().splitlines()
    assert lines == [",".join(CORR_COLUMNS)]  # header only: nothing matched


def test_progress_bar_on_a_terminal_lines_otherwise_none_with_quiet(monkeypatch):
    import contextlib
    import io
    import sys

    from startrack.cli._identify_output import inputs_with_progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    inputs = ("a", "b", "c")
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    with contextlib.ExitStack() as stack:
        assert inputs_with_progress(inputs, True, stack) is inputs
        # not a terminal: the inputs counted for progress lines (none in a short run)
        assert list(inputs_with_progress(inputs, False, stack)) == list(inputs)
    assert sys.stderr.getvalue() == ""
    monkeypatch.setattr(sys, "stderr", Terminal())
    with contextlib.ExitStack() as stack:
        assert inputs_with_progress(inputs, True, stack) is inputs
        assert list(inputs_with_progress(inputs, False, stack)) == list(inputs)
    assert "identify" in sys.stderr.getvalue()


def test_a_radial_distortion_model_becomes_exact_sip_terms():
    from types import SimpleNamespace

    from startrack.attitude import from_radec_roll
    from startrack.sky import vectors_to_radec

    pinhole = Camera.from_fov(1024, 768, 20.0)
    k1 = -0.3  # strong barrel distortion: ~15 px at the corners
    cam = SimpleNamespace(width=1024, height=768, f_px=pinhole.f_px, cx=pinhole.cx,
                          cy=pinhole.cy, fov_deg=pinhole.fov_deg,
                          distortion={"model": "radial", "k1": k1})
    rot = from_radec_roll(120.0, 35.0, 75.0)
    header = wcs_header(cam, rot)
    assert header["CTYPE1"] == "RA---TAN-SIP" and header["AP_ORDER"] == 7
    w = WCS(header)
    rng = np.random.default_rng(1)
    xi, yi = rng.uniform(0, 1023, 200), rng.uniform(0, 767, 200)  # ideal pinhole pixels
    u, v = (xi - cam.cx) / cam.f_px, (yi - cam.cy) / cam.f_px
    scale = 1 + k1 * (u ** 2 + v ** 2)
    xo, yo = cam.cx + cam.f_px * u * scale, cam.cy + cam.f_px * v * scale  # observed
    ra, dec = vectors_to_radec(rot.apply(pinhole.pixel_to_vector(xi, yi)))
    got_ra, got_dec = w.all_pix2world(xo, yo, 0)
    sep = SkyCoord(got_ra, got_dec, unit="deg").separation(SkyCoord(ra, dec, unit="deg"))
    assert sep.arcsec.max() < 1.0  # the fitted A/B invert the model to well under 1"
    back_x, back_y = w.all_world2pix(ra, dec, 0)
    assert np.hypot(back_x - xo, back_y - yo).max() < 0.05
