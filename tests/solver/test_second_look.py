"""Issue 49: a frame whose brightest spots are not stars (a burned-in caption, hot pixels,
nebula knots) is searched again past them, and the answer is numbered in the whole
frame; random spots stay unsolved."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from startrack.api import Solver
from startrack.attitude import boresight_error_arcsec, random_attitudes
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.matchers import IMAGE_STARS
from startrack.sky import SkySpec, load_sky
from startrack.solver._deeper import CROWDING, SKIP, reordered, second_look_order
from tests.solver.test_principal_point import FOV, SIZE, WRONG_ARCSEC, _centroids

CAPTION = 12  # bright junk spots, brighter than every star


@pytest.fixture(scope="module")
def hipparcos():
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), Camera.from_fov(SIZE, SIZE, FOV))


def _captioned(hipparcos, seed: int):
    """A frame's stars (fluxes falling with rank) under a caption: CAPTION spots in a
    row along the bottom edge, brighter than any star. (spots, rotation)."""
    rng = np.random.default_rng(seed)
    rotation = random_attitudes(1, rng)[0]
    xy, _ = _centroids(hipparcos, Camera.from_fov(SIZE, SIZE, FOV), rotation, rng)
    stars = np.column_stack([xy, 1000.0 / (1.0 + np.arange(len(xy)))])
    caption = np.column_stack([40.0 + 23.0 * np.arange(CAPTION), np.full(CAPTION, 1000.0),
                               np.full(CAPTION, 5000.0)])
    return np.vstack([caption, stars]), rotation


@pytest.mark.parametrize("seed", [3, 4])
def test_a_captioned_frame_is_solved_past_its_caption(hipparcos, seed):
    spots, rotation = _captioned(hipparcos, seed)
    solver = Solver(fov_deg=FOV * 1.04, size=(SIZE, SIZE), sky="hipparcos", mag_limit=6.5)
    # the stars alone solve; with the caption on top the first look matches nothing
    assert solver.solve(spots[CAPTION:]).solved
    result = solver.solve(spots)
    record = result.to_dict()
    assert result.solved, record["steps"]
    assert any("second look" in s["stage"] for s in record["steps"])
    assert boresight_error_arcsec(rotation, result.frame.solution.rotation) < WRONG_ARCSEC
    labelled = result.frame.solution.obs_index
    assert labelled.min() >= SKIP and not np.isin(labelled, np.arange(CAPTION)).any()


def test_random_spots_get_no_second_look_answer():
    rng = np.random.default_rng(49)
    solver = Solver(fov_deg=FOV * 1.04, size=(SIZE, SIZE), sky="hipparcos", mag_limit=6.5)
    for _ in range(5):
        spots = np.column_stack([rng.uniform(0, SIZE - 1, (60, 2)), rng.uniform(1, 100, 60)])
        result = solver.solve(spots)
        assert not result.solved and result.reason == "no_match"
        assert any("second look" in s["stage"] for s in result.to_dict()["steps"])


def _spots(saturated: list[bool]) -> Centroids:
    n = len(saturated)
    return Centroids(np.arange(n, dtype=float), np.zeros(n), np.arange(n, 0, -1.0),
                     np.array(saturated))


def test_saturated_pattern_spots_put_the_unsaturated_first():
    spots = _spots([True] * CROWDING + [False] * 30)
    order, stage = second_look_order(spots)
    assert stage == "second look, unsaturated spots first"
    assert list(order[:30]) == list(range(CROWDING, CROWDING + 30))
    assert list(order[30:]) == list(range(CROWDING))
    # a saturated spot past the pattern stars, or too few unsaturated spots: the old rule
    for flags in ([True] * (CROWDING - 1) + [False] * 30,
                  [False] * IMAGE_STARS + [True] * 10,
                  [True] * CROWDING + [False] * (IMAGE_STARS - 1)):
        order, stage = second_look_order(_spots(flags))
        assert stage == f"second look, past the {SKIP} brightest spots"
        assert list(order) == list(range(SKIP, len(flags)))


def test_a_reordered_frame_keeps_each_spot_and_numbers_answers_back():
    spots = _spots([True] * CROWDING + [False] * 30)
    order, _ = second_look_order(spots)
    look = reordered(spots, order)
    assert np.array_equal(look.x, spots.x[order]) and not look.photometric
    assert np.array_equal(look.saturated, spots.saturated[order])
    skip = reordered(spots, np.arange(SKIP, len(spots)))
    assert skip.photometric and np.array_equal(skip.flux, spots.flux[SKIP:])


def _rendered(hipparcos, seed: int, caption: bool) -> tuple[np.ndarray, object]:
    """An 8-bit frame of the stars of a random attitude (none saturated), with a guide
    camera's white caption burned in across its top when ``caption``."""
    rng = np.random.default_rng(seed)
    rotation = random_attitudes(1, rng)[0]
    xy, _ = _centroids(hipparcos, Camera.from_fov(SIZE, SIZE, FOV), rotation, rng)
    yy, xx = np.mgrid[0:SIZE, 0:SIZE]
    image = rng.normal(12.0, 2.0, (SIZE, SIZE))
    for rank, (x, y) in enumerate(xy[:60]):
        near = (np.abs(xx - x) < 6) & (np.abs(yy - y) < 6)
        peak = 200.0 / (1.0 + 0.15 * rank)
        image[near] += peak * np.exp(-((xx[near] - x) ** 2 + (yy[near] - y) ** 2) / 2.9)
    image = np.clip(image, 0, 255).astype(np.uint8)
    if caption:
        for row, text in enumerate(("GUIDER 2026-12-07 02:14:55 UT", "EXP 2.0 s GAIN 300 T -5C")):
            cv2.putText(image, text, (20, 40 + 40 * row), cv2.FONT_HERSHEY_SIMPLEX, 1.0, 255, 1)
    return image, rotation


@pytest.mark.parametrize("seed", [5, 6])
def test_a_frame_under_a_saturated_caption_is_solved_from_its_unsaturated_stars(hipparcos,
                                                                                seed):
    solver = Solver(fov_deg=FOV * 1.04, size=(SIZE, SIZE), sky="hipparcos", mag_limit=6.5)
    clean, rotation = _rendered(hipparcos, seed, caption=False)
    assert solver.solve(clean).solved
    image, _ = _rendered(hipparcos, seed, caption=True)
    result = solver.solve(image)
    stages = [s["stage"] for s in result.to_dict()["steps"]]
    assert result.solved, stages
    assert "second look, unsaturated spots first" in stages
    assert boresight_error_arcsec(rotation, result.frame.solution.rotation) < WRONG_ARCSEC


def test_the_first_looks_tables_go_only_when_the_first_look_grew_the_process(monkeypatch):
    import startrack.solver._deeper as deeper

    big = 40 * 2**30  # a process holding much already (a bench, a compare)
    monkeypatch.setattr(deeper, "resident_bytes", lambda: big)
    assert not deeper.tables_to_release(big - deeper.RELEASE_GROWTH_BYTES)
    assert deeper.tables_to_release(big - deeper.RELEASE_GROWTH_BYTES - 1)
    assert deeper.tables_to_release(None)  # unreadable at the start: let go
    monkeypatch.setattr(deeper, "resident_bytes", lambda: None)
    assert deeper.tables_to_release(big)


def test_a_second_look_keeps_a_wide_fields_search_when_memory_is_low(monkeypatch):
    # junk frames at 20 deg: each one's second look used to drop the deeper sky's search
    # and build it again for the next frame (120 ms of cone index and a 47 ms collection)
    import startrack.solver._deeper as deeper
    import startrack.solver._pipeline as flow
    from startrack.solver import FrameInput, Options, Pipeline

    monkeypatch.setattr(deeper, "RELEASE_GROWTH_BYTES", 2**62)
    asked = []
    monkeypatch.setattr(flow, "tables_to_release",
                        lambda held: asked.append(1) or deeper.tables_to_release(held))
    pipeline = Pipeline(Options(fov_deg=FOV * 1.04, size=(SIZE, SIZE)))
    rng = np.random.default_rng(5)
    kept = []
    for k in range(3):
        x, y = rng.uniform(0, SIZE - 1, (2, 40))
        result = pipeline.solve(FrameInput(f"junk{k}", Centroids(x, y, rng.uniform(1, 100, 40))))
        assert not result.solution.solved and len(asked) == k + 1  # a second look ran
        kept.append({id(search) for search in pipeline._blind.values()})
    assert kept[0] and kept[0] == kept[1] == kept[2]
