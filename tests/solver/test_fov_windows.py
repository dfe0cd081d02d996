"""The order of the focal-length windows a nominal or unknown field of view is searched in
(startrack.solver._fov_windows.passes): with a nominal focal length the strong lookups
start at the window centred on it and go outward; the windows still cover the range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from startrack.solver._fov_windows import WINDOW_STEP, centred_windows, passes, windows

STEP = WINDOW_STEP ** 2


def _covers(spans, f_lo, f_hi) -> None:
    """``spans`` tile [f_lo, f_hi]: sorted, each starts where the one before ends."""
    ordered = sorted(spans)
    assert ordered[0][0] == f_lo and ordered[-1][1] == f_hi
    for (_, end), (start, _) in zip(ordered[:-1], ordered[1:], strict=True):
        assert start == end


@pytest.mark.parametrize("f_lo, f_hi", [(800.0, 2400.0), (1000.0, 1300.0), (500.0, 5000.0)])
def test_centred_windows_tile_the_range_nearest_first(f_lo, f_hi):
    rng = np.random.default_rng(2)
    for centre in np.concatenate([rng.uniform(f_lo, f_hi, 20), [f_lo, f_hi, f_lo / 2, 3 * f_hi]]):
        spans = centred_windows(f_lo, f_hi, float(centre), STEP)
        _covers(spans, f_lo, f_hi)
        held = min(max(centre, f_lo), f_hi)
        assert spans[0][0] <= held <= spans[0][1]  # the first holds the centre
        assert all(hi / lo <= STEP * (1 + 1e-12) for lo, hi in spans[1:])
        assert spans[0][1] / spans[0][0] <= STEP ** 1.5  # a step, and at most two slivers
        near = [min(abs(math.log(lo / held)), abs(math.log(hi / held))) for lo, hi in spans]
        assert near[1:] == sorted(near[1:])


def test_a_range_no_wider_than_a_window_is_one_window_either_way():
    f_lo, f_hi = 1000.0, 1250.0
    assert centred_windows(f_lo, f_hi, 1100.0, STEP) == [(f_lo, f_hi)]
    assert windows(f_lo, f_hi, STEP) == [(f_lo, f_hi)]


def test_passes_with_a_nominal_start_at_it_and_keep_the_ranked_windows():
    f_lo, f_hi = 800.0, 2400.0
    blind, nominal = passes(f_lo, f_hi), passes(f_lo, f_hi, 1500.0)
    strong = [(p.f_lo, p.f_hi) for p in nominal if p.strong_only]
    assert strong[0][0] <= 1500.0 <= strong[0][1]
    assert [(p.f_lo, p.f_hi) for p in blind if p.strong_only] == windows(f_lo, f_hi, STEP)
    _covers(strong, f_lo, f_hi)
    # the ranked windows, at both levels, are the same whatever the nominal
    assert [p for p in nominal if not p.strong_only] == [p for p in blind if not p.strong_only]
