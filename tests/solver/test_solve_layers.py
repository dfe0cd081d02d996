"""The shortcuts of one solve's Python layers (startrack.solver._pipeline, startrack.match_records,
startrack.verify._evidence) give what the long way gives."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.errors import InputError
from startrack.match_records import Observation, Solution, Timing
from startrack.sky import SkySpec, load_sky
from startrack.solver._fov_search import FovResult
from startrack.solver._identifier import FrameResult, Identifier
from startrack.solver._pipeline import FrameInput, Options, Pipeline
from startrack.verify import _evidence
from startrack.verify._evidence import MIN_MATCHED

CAMERA = Camera.from_fov(1024, 1024, 20.0)


def _centroids(n: int = 5) -> Centroids:
    return Centroids(np.linspace(10.0, 900.0, n), np.linspace(20.0, 800.0, n),
                     np.arange(n, 0, -1, dtype=float))


def test_with_timing_changes_the_timing_alone():
    values = {"input": "a", "solution": Solution(False, "pyramid"), "obs": None,
              "centroids": _centroids(), "timing": Timing(1.0, 2.0, 3.0), "camera": CAMERA,
              "catalog": None, "sigma_px": 0.5, "match_radius_px": 2.0,
              "image": np.zeros((2, 2)), "time_utc": "2025-01-01T00:00:00.000",
              "request": {"method": "pyramid"}, "steps": ({"stage": "method"},)}
    assert set(values) == {f.name for f in dataclasses.fields(FrameResult)}
    result = FrameResult(**values)
    timing = Timing(1.0, 2.0, 3.0, 4.0)
    made = result.with_timing(timing)
    assert made.timing is timing
    for name in values.keys() - {"timing"}:
        assert getattr(made, name) is getattr(result, name)


def test_plus_ms_adds_the_time_alone():
    sol = Solution(True, "quad", identify_ms=1.5, false_probability=1e-12)
    found = FovResult(sol, CAMERA, None, None, 2.0).plus_ms(0.25)
    assert found.solution.identify_ms == 1.75
    assert dataclasses.replace(found.solution, identify_ms=1.5) == sol
    assert (found.camera, found.match_radius_px) == (CAMERA, 2.0)


def test_setup_is_decided_once_per_options_and_image_size():
    pipeline = Pipeline(Options(fov_deg=20.0, sky="random", fov_tolerance=0.0))
    small = FrameInput("a", _centroids(), image=np.zeros((768, 1024)))
    camera, sky = pipeline.setup_for(small)
    assert camera == CAMERA.__class__.from_fov(1024, 768, 20.0)
    assert pipeline.setup_for(small)[0] is camera and pipeline.setup_for(small)[1] is sky
    wide = pipeline.setup_for(FrameInput("b", _centroids(), image=np.zeros((512, 2048))))[0]
    assert (wide.width, wide.height) == (2048, 512)
    pipeline.options = dataclasses.replace(pipeline.options, fov_deg=10.0)  # new options
    assert pipeline.setup_for(small)[0].fov_deg == pytest.approx(10.0)
    for name in ("first.csv", "second.csv"):  # an error is never remembered for another
        with pytest.raises(InputError, match=name):
            pipeline.setup_for(FrameInput(name, _centroids()))


def test_identifier_is_the_one_held_for_its_camera_and_sky():
    pipeline = Pipeline(Options(camera=CAMERA, sky="random", fov_tolerance=0.0))
    camera, sky = pipeline.setup_for(FrameInput("a", _centroids()))
    ident = pipeline.identifier(camera, sky)
    assert pipeline.identifier(camera, sky) is ident
    assert pipeline.identifier(dataclasses.replace(camera), SkySpec(**vars(sky))) is ident
    assert pipeline.identifier(camera, sky, "quad") is not ident
    assert ident.first_look is ident.first_look  # made once


def _solved(residuals: np.ndarray) -> Solution:
    n = len(residuals)
    return Solution(True, "pyramid", Rotation.identity(), np.arange(n), np.arange(n),
                    residuals)


@pytest.mark.filterwarnings("ignore:overflow encountered")
@pytest.mark.parametrize("residuals, problem", [
    ([1.0, np.nan, 1.0, 1.0, 1.0], "no finite residual"),
    ([1.0, np.inf, 1.0, 1.0, 1.0], "no finite residual"),
    ([1e200, 1e200, 1.0, 1.0, 1.0], "residual RMS inf px"),  # squares overflow
    ([1.0, 2.0, 3.0, 4.0, 5000.0], "residual RMS"),
])
def test_evidence_problems_are_named(residuals, problem):
    sol = _solved(np.array(residuals[:MIN_MATCHED] + [1.0] * (MIN_MATCHED - 5)))
    assert problem in _evidence.evidence_problem(sol, CAMERA.f_px, 2.0)


def test_evidence_rms_is_numpys_mean_of_squares():
    rng = np.random.default_rng(5)
    for _ in range(200):
        res = rng.uniform(0, 30, rng.integers(MIN_MATCHED, 60))
        rms_px = np.sqrt(float(np.mean(res ** 2))) / _evidence.ARCSEC_PER_RAD * CAMERA.f_px
        at = float(rms_px)  # a radius exactly at the RMS passes, one ulp below does not
        assert _evidence.evidence_problem(_solved(res), CAMERA.f_px, at) is None
        assert _evidence.evidence_problem(_solved(res), CAMERA.f_px,
                                          np.nextafter(at, 0.0)) is not None


def test_a_solve_through_the_pipeline_reports_its_setup_once():
    catalog = load_sky(SkySpec(kind="random"))
    ident = Identifier(CAMERA, catalog, "pyramid")
    obs = Observation.from_pixels(np.zeros(2), np.zeros(2), CAMERA, 0.5)
    assert ident.identify(obs).reason == "too_few_stars"
    pipeline = Pipeline(Options(camera=CAMERA, sky="random", fov_tolerance=0.0))
    # three stars at least: fewer are answered before any sky is loaded (no setup at all)
    first = pipeline.solve(FrameInput("a", _centroids(4)))
    again = pipeline.solve(FrameInput("a", _centroids(4)))
    assert first.timing.setup > 0.0 and again.timing.setup == 0.0
    assert not again.solution.solved
    few = pipeline.solve(FrameInput("a", _centroids(2)))
    assert few.solution.reason == "too_few_stars" and few.timing.setup == 0.0
