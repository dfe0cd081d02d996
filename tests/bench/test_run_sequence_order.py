"""The tracking bench's sequence runs each frame by every method in turn, or each method
through the whole sequence (a tracker in flight, nothing between its frames): the same
rows either way."""

import pytest

from startrack.bench._tracking_bench import TrackCondition, make_sequence, run_sequence
from startrack.match_records import Solution


@pytest.mark.parametrize("interleaved", [True, False])
def test_every_frame_by_every_method_in_the_order_asked(hip_db, interleaved):
    seq = make_sequence(hip_db.catalog, hip_db.camera, TrackCondition(), 3, 10.0, seed=2)
    calls = []

    def recorder(name):
        def make():
            def run(obs):
                calls.append((name, next(k for k, f in enumerate(seq) if f.obs is obs)))
                return Solution(False, name, reason="no_match")
            return run
        return make

    df = run_sequence(seq, {"one": recorder("one"), "two": recorder("two")},
                      interleaved=interleaved)
    want = ([("one", 0), ("two", 0), ("one", 1), ("two", 1), ("one", 2), ("two", 2)]
            if interleaved else
            [("one", 0), ("one", 1), ("one", 2), ("two", 0), ("two", 1), ("two", 2)])
    assert calls == want
    assert list(zip(df["method"], df["frame"], strict=True)) == want
    assert not df["solved"].any()
