"""Bench scoring, conditions and frames: hand-made solutions and the pairing of conditions."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from startrack.bench._conditions import Condition, build_conditions, parse_values, sweep
from startrack.bench._frames import make_frame
from startrack.bench._metrics import score_frame, summarise
from startrack.camera import Camera
from startrack.errors import InputError
from startrack.match_records import MatchDiagnostics, Solution
from startrack.sky import SkySpec, load_sky

TRUTH = Rotation.from_euler("zyx", [30.0, -20.0, 10.0], degrees=True)
TRUTH_ROWS = np.array([4, 9, -1, 12, 20])  # observed star 2 is a false star


def _solution(obs_index, cat_index, rotation=TRUTH) -> Solution:
    return Solution(True, "test", rotation, np.asarray(obs_index), np.asarray(cat_index))


def _turn(axis, arcsec) -> Rotation:
    """TRUTH turned by ``arcsec`` about a camera axis (x: pointing moves, z: roll)."""
    vec = np.zeros(3)
    vec["xyz".index(axis)] = math.radians(arcsec / 3600.0)
    return TRUTH * Rotation.from_rotvec(vec)


def test_right_ids_and_attitude_are_correct():
    s = score_frame(_solution([0, 1, 3, 4], [4, 9, 12, 20]), TRUTH_ROWS, TRUTH, 6)
    assert s.solved and s.correct and not s.wrong
    assert (s.n_identified, s.n_id_correct, s.n_id_wrong) == (4, 4, 0)
    assert (s.n_observed, s.n_real_observed, s.n_true_in_view) == (5, 4, 6)
    assert s.error_arcsec < 1e-6 and s.boresight_error_arcsec < 1e-6


def test_one_wrong_id_makes_a_wrong_solution():
    s = score_frame(_solution([0, 1, 3], [4, 9, 13]), TRUTH_ROWS, TRUTH, 6)
    assert s.solved and s.wrong and not s.correct
    assert (s.n_id_correct, s.n_id_wrong) == (2, 1)


def test_a_false_star_given_an_identity_is_wrong():
    s = score_frame(_solution([0, 1, 2], [4, 9, 30]), TRUTH_ROWS, TRUTH, 6)
    assert s.wrong and s.n_id_wrong == 1


def test_pointing_off_by_more_than_the_threshold_is_wrong():
    s = score_frame(_solution([0, 1, 3], [4, 9, 12], _turn("x", 90.0)), TRUTH_ROWS, TRUTH, 6)
    assert s.wrong
    assert s.boresight_error_arcsec == pytest.approx(90.0, rel=1e-6)
    s = score_frame(_solution([0, 1, 3], [4, 9, 12], _turn("x", 30.0)), TRUTH_ROWS, TRUTH, 6)
    assert s.correct


def test_roll_error_alone_does_not_fail_a_right_identification():
    s = score_frame(_solution([0, 1, 3], [4, 9, 12], _turn("z", 200.0)), TRUTH_ROWS, TRUTH, 6)
    assert s.correct
    assert s.roll_error_arcsec == pytest.approx(200.0, rel=1e-6)
    assert s.error_arcsec == pytest.approx(200.0, rel=1e-6)
    assert s.boresight_error_arcsec < 1e-3


def test_threshold_grows_with_the_stated_centroid_noise():
    sol = _solution([0, 1, 3], [4, 9, 12], _turn("y", 100.0))
    assert score_frame(sol, TRUTH_ROWS, TRUTH, 6, sigma_arcsec=0.0).wrong
    assert score_frame(sol, TRUTH_ROWS, TRUTH, 6, sigma_arcsec=30.0).correct
    assert score_frame(sol, TRUTH_ROWS, TRUTH, 6, threshold_arcsec=120.0).correct


def test_not_solved_is_neither_correct_nor_wrong():
    s = score_frame(Solution(False, "test"), TRUTH_ROWS, TRUTH, 6)
    assert not (s.solved or s.correct or s.wrong)
    assert s.n_identified == 0 and math.isnan(s.error_arcsec)


def test_a_peer_is_timed_by_its_solve_call_alone():
    ours = Solution(True, "test", TRUTH, np.array([0, 1, 3]), np.array([4, 9, 12]),
                    identify_ms=5.0)
    assert score_frame(ours, TRUTH_ROWS, TRUTH, 6).method_ms == 5.0
    peer = Solution(True, "peer", TRUTH, np.array([0, 1, 3]), np.array([4, 9, 12]),
                    diagnostics=MatchDiagnostics(method_ms=1.5), identify_ms=5.0)
    score = score_frame(peer, TRUTH_ROWS, TRUTH, 6)
    assert (score.method_ms, score.identify_ms) == (1.5, 5.0)


def test_summary_rates_precision_and_recall():
    frames = pd.DataFrame({
        "condition": [0, 0, 0, 0], "method": ["a", "a", "a", "a"],
        "solved": [1, 1, 1, 0], "correct": [1, 1, 0, 0], "wrong": [0, 0, 1, 0],
        "n_identified": [5, 4, 3, 0], "n_id_correct": [5, 4, 1, 0],
        "n_real_observed": [5, 5, 5, 5], "error_arcsec": [1.0, 3.0, 5000.0, np.nan],
        "boresight_error_arcsec": [0.5, 1.0, 900.0, np.nan],
        "roll_error_arcsec": [1.0, 3.0, 5000.0, np.nan],
        # The summary times the method's own call (a peer's solve), not the identify call.
        "identify_ms": [11.0, 12.0, 13.0, 20.0], "method_ms": [1.0, 2.0, 3.0, 10.0],
        "centroid_ms": [0.0] * 4,
    })
    row = summarise(frames, ["condition", "method"]).iloc[0]
    assert row["frames"] == 4 and row["wrong"] == 1
    assert (row["solved_rate"], row["correct_rate"], row["wrong_rate"]) == (0.75, 0.5, 0.25)
    assert row["star_precision"] == pytest.approx(10 / 12)
    assert row["star_recall"] == pytest.approx(10 / 20)
    assert row["error_median_arcsec"] == pytest.approx(2.0)  # correct solutions only
    assert row["time_median_ms"] == pytest.approx(2.5)
    assert row["time_mean_ms"] == pytest.approx(4.0)


def test_conditions_one_at_a_time_and_full():
    levels = {"noise_px": (0.5, 0.0, 1.0), "false_stars": (0, 2), "missing": (0.0,),
              "mag_noise": (0.0,)}
    oat = build_conditions(levels)
    assert len(oat) == 1 + 2 + 1 and oat[0] == Condition(0.5, 0, 0.0, 0.0)
    assert [oat[k].noise_px for k in sweep(oat, "noise_px")] == [0.0, 0.5, 1.0]
    assert all(oat[k].false_stars == 0 for k in sweep(oat, "noise_px"))
    full = build_conditions(levels, "full")
    assert len(full) == 6 and len(set(full)) == 6
    assert [full[k].false_stars for k in sweep(full, "false_stars")] == [0, 2]


@pytest.mark.parametrize("text", ["", "0,,1", "a,b", "-1", "1,1", "nan"])
def test_bad_value_lists_are_input_errors(text):
    with pytest.raises(InputError, match="--noise-px"):
        parse_values(text, "--noise-px")


def test_integer_lists_refuse_fractions():
    assert parse_values("0, 1,3", "--false-stars", integer=True) == (0, 1, 3)
    with pytest.raises(InputError):
        parse_values("0.5", "--false-stars", integer=True)


@pytest.fixture(scope="module")
def sky():
    return load_sky(SkySpec(kind="random", n_stars=2000, seed=0)), Camera.from_fov(1024, 1024, 17.5)


def test_conditions_are_paired_comparisons(sky):
    catalog, camera = sky
    base = make_frame(catalog, camera, Condition(), 11, 3)
    assert np.all(base.truth_rows >= 0) and base.n_in_view == len(base.truth_rows)
    noisy = make_frame(catalog, camera, Condition(noise_px=1.0), 11, 3)
    noisier = make_frame(catalog, camera, Condition(noise_px=2.0), 11, 3)
    np.testing.assert_array_equal(noisy.truth_rows, base.truth_rows)
    # the same normals, scaled by the noise level
    np.testing.assert_allclose(noisier.obs.x - base.obs.x, 2 * (noisy.obs.x - base.obs.x),
                               atol=1e-9)
    assert np.std(noisy.obs.x - base.obs.x) > 0.3
    few = make_frame(catalog, camera, Condition(missing=0.4), 11, 3)
    fewer = make_frame(catalog, camera, Condition(missing=0.8), 11, 3)
    assert set(fewer.truth_rows) <= set(few.truth_rows) <= set(base.truth_rows)
    one = make_frame(catalog, camera, Condition(false_stars=1), 11, 3)
    three = make_frame(catalog, camera, Condition(false_stars=3), 11, 3)
    assert (one.truth_rows == -1).sum() == 1 and (three.truth_rows == -1).sum() == 3
    assert one.obs.x[one.truth_rows == -1][0] in three.obs.x[three.truth_rows == -1]
    other = make_frame(catalog, camera, Condition(), 11, 4)
    assert not np.array_equal(other.truth_rows, base.truth_rows)
