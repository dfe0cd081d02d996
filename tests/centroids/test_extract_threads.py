"""The centroider on threads: the same centroids, bit for bit and in the same order, for
any number of threads and any cut of the frame into bands."""

import multiprocessing

import numpy as np
import pytest
from repo_paths import DATA
from scipy import ndimage
from waiting import CHILD_TIMEOUT_S

from startrack._core.centroids import blobs
from startrack._core.centroids import extract as runs
from startrack.centroids import _threads as par
from startrack.centroids._extract import CentroidConfig, _sky_model, extract_centroids
from startrack.io import read_image

REAL_SKY = DATA / "realsky_azi45.png"


def starry_frame(seed=4, shape=(640, 700)):
    """A glowing 16-bit sky with stars everywhere (some on the bands' edges for 2 to 6
    bands), a saturated bloom, hot pixels and long streaks across rows."""
    rng = np.random.default_rng(seed)
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w]
    image = 1500.0 + 2.0 * cols + 0.5 * rows + rng.normal(0.0, 12.0, shape)
    edges = sorted({h * i // p for p in range(2, 7) for i in range(1, p)})
    ys = np.r_[edges, rng.uniform(3, h - 4, 150)]
    xs = rng.uniform(3, w - 4, len(ys))
    for x, y, f in zip(xs, ys, rng.uniform(300, 2e4, len(ys)), strict=True):
        r0, c0 = int(y) - 6, int(x) - 6
        sub = (slice(max(r0, 0), r0 + 13), slice(max(c0, 0), c0 + 13))
        d2 = (rows[sub] - y) ** 2 + (cols[sub] - x) ** 2
        image[sub] += f / (2 * np.pi * 1.4**2) * np.exp(-d2 / (2 * 1.4**2))
    image[200:240, 300:303] += 900.0  # a streak over many rows
    image[h // 2 - 8:h // 2 + 8, 100:116] = 65535.0  # a saturated bloom on a band edge
    image[rng.integers(0, h, 30), rng.integers(0, w, 30)] = 30000.0  # hot pixels
    return np.clip(image, 0, 65535).astype(np.uint16)


def same(a, b):
    return all(np.array_equal(getattr(a, k), getattr(b, k))
               for k in ("x", "y", "flux", "saturated", "area")) and len(a) > 0


@pytest.mark.parametrize("settings", [{}, {"fast": True}, {"smooth": False}])
def test_any_thread_count_gives_the_same_centroids(settings):
    image = starry_frame()
    assert par.parts_for(6, image.size) == 6  # the frame is cut into up to 6 bands
    one = extract_centroids(image, CentroidConfig(threads=1, **settings))
    assert len(one) > 100 and one.saturated.any()
    for threads in (2, 3, 6):
        assert same(extract_centroids(image, CentroidConfig(threads=threads, **settings)),
                    one), threads


def test_float_frame_with_dead_pixels_same_on_threads():
    image = starry_frame(seed=9).astype(np.float32)
    image[100:130, 40:90] = np.nan
    image[400, :] = np.inf
    one = extract_centroids(image, CentroidConfig(threads=1))
    assert same(extract_centroids(image, CentroidConfig(threads=4)), one)


def test_real_frame_same_on_two_threads():
    image = read_image(REAL_SKY)
    one = extract_centroids(image, CentroidConfig(threads=1))
    assert len(one) > 20
    assert same(extract_centroids(image, CentroidConfig(threads=2)), one)


def components(image, cuts, smooth=False, threshold=1500.0):
    """Components above a flat sky of 1000, the rows cut into bands at ``cuts``."""
    model = _sky_model(np.full(image.shape, 1000, np.uint16), 31, True, 1)
    pieces = [runs.band_runs(image, model, threshold, smooth, np.inf, a, b)
              for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    return blobs.join_runs(np.concatenate([p[0] for p in pieces]),
                           np.concatenate([p[1] for p in pieces]))


def test_band_cuts_do_not_change_components():
    image = np.full((120, 90), 1000, np.uint16)
    image[10:100:3, 20:70] = 9000  # a comb: joined only at its spine, in the last rows
    image[10:100, 68:70] = 9000
    image[50:54, 5:9] = 9000
    image[60, 80], image[61, 81] = 9000, 9000  # diagonal neighbours on a cut
    for smooth in (False, True):
        whole = components(image, [0, 120], smooth)
        assert len(whole) == 3
        for cuts in ([0, 60, 61, 120], [0, 1, 2, 11, 12, 50, 51, 119, 120], list(range(121))):
            np.testing.assert_array_equal(components(image, cuts, smooth), whole)


def test_components_are_the_8_connected_labels():
    rng = np.random.default_rng(2)
    image = (1000 + 9000 * (rng.random((150, 170)) < 0.25)).astype(np.uint16)
    found = components(image, [0, 37, 38, 100, 150])
    labels, n = ndimage.label(image > 5000, np.ones((3, 3)))
    assert len(found) == n
    np.testing.assert_array_equal(np.sort(found[:, runs.COLUMNS["area"]]),
                                  np.sort(np.bincount(labels.ravel())[1:]).astype(float))


def test_thread_count_and_bands(monkeypatch):
    monkeypatch.setattr(par, "usable_cores", lambda: 1)
    assert par.thread_count(None) == 1 and par.thread_count(3) == 3
    monkeypatch.setattr(par, "usable_cores", lambda: 4)
    monkeypatch.setattr(par.os, "cpu_count", lambda: 4)
    monkeypatch.setattr(par.os, "getloadavg", lambda: (1.2, 0.0, 0.0))
    assert par.thread_count(None) == 4  # the load is this process's own thread
    monkeypatch.setattr(par.os, "getloadavg", lambda: (3.6, 0.0, 0.0))
    assert par.thread_count(None) == 1 and par.thread_count(4) == 4  # busy: one, if free
    assert par.bands(10, 3) == [(0, 3), (3, 6), (6, 10)]
    assert par.bands(2, 5) == [(0, 1), (1, 2)]
    assert par.parts_for(8, 100) == 1  # a small frame stays on one thread
    with pytest.raises(ValueError, match="threads"):
        CentroidConfig(threads=0)


def _child(queue):
    found = extract_centroids(starry_frame(), CentroidConfig(threads=2))
    queue.put(len(found))


def test_threads_work_in_a_forked_child():
    extract_centroids(starry_frame(), CentroidConfig(threads=2))  # the parent's pool
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue,))
    child.start()
    child.join(CHILD_TIMEOUT_S)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung on the parent's thread pool")
    assert queue.get(timeout=5) > 100


def test_run_keeps_order_and_raises_a_helpers_error():
    args = [(i,) for i in range(11)]
    for threads in (1, 2, 5):
        assert par.run(lambda i: i * i, args, threads) == [i * i for i in range(11)]

    def fails_late(i):
        if i == 10:
            raise KeyError("piece 10")
        return i

    for _ in range(5):  # whoever takes the last piece, the caller raises its error
        with pytest.raises(KeyError, match="piece 10"):
            par.run(fails_late, args, 3)


def test_callers_on_their_own_threads_get_the_same_centroids():
    from concurrent.futures import ThreadPoolExecutor

    image = starry_frame()
    one = extract_centroids(image, CentroidConfig(threads=1))
    with ThreadPoolExecutor(3) as pool:
        found = list(pool.map(lambda t: extract_centroids(image, CentroidConfig(threads=t)),
                              [2, 3, 2, 4, 1, 2]))
    assert all(same(f, one) for f in found)
