"""The bench's false-star magnitude rules (startrack.bench._frames): uniform over the stars
in view, or fainter than the fifth brightest real star (the 2011 section's sensitivity)."""

import numpy as np
import pytest

from startrack.bench._conditions import Condition
from startrack.bench._frames import make_frame
from startrack.camera import Camera
from startrack.sky import random_sky

CAMERA = Camera.from_fov(1024, 1024, 17.5)
SKY = random_sky(2000, seed=11)


def _top5_real(rule: str, frames: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Per frame (5 false stars): real stars among the five brightest spots, and in all."""
    made = [make_frame(SKY, CAMERA, Condition(false_stars=5), 3, i, false_mags=rule)
            for i in range(frames)]
    return (np.array([np.count_nonzero(f.truth_rows[:5] >= 0) for f in made]),
            np.array([np.count_nonzero(f.truth_rows >= 0) for f in made]))


def test_faint_false_stars_leave_the_five_brightest_real():
    (faint, real), (uniform, _) = _top5_real("faint"), _top5_real("uniform")
    np.testing.assert_array_equal(faint, np.minimum(5, real))
    assert uniform.mean() < faint.mean(), "uniform false stars push real ones out"


def test_the_rules_share_positions_and_an_unknown_rule_is_refused():
    a = make_frame(SKY, CAMERA, Condition(false_stars=3), 3, 0, false_mags="faint")
    b = make_frame(SKY, CAMERA, Condition(false_stars=3), 3, 0)
    assert sorted(a.obs.x) == pytest.approx(sorted(b.obs.x))
    with pytest.raises(ValueError, match="false_mags"):
        make_frame(SKY, CAMERA, Condition(false_stars=1), 3, 0, false_mags="bright")
