"""scripts/bench/bench_paths.py gives startrack and its peers the same information on every
path, and scores junk and truth frames as the rest of the benches do."""

import math

import numpy as np
import pytest

from scripts.bench.bench_paths import (
    DEFAULT_PEERS,
    doc_marker,
    junk_frames,
    paths,
    score,
    solve_order,
    table,
    told,
)
from startrack.camera import Camera
from startrack.input_checks import FOV_TOLERANCE


@pytest.mark.parametrize("span", [1.2, 1.5, 1.7])
def test_range_row_searches_the_peers_range(span):
    (label, kind, tolerance, err), = [p for p in paths(span) if p[1] == "range"]
    fov = 20.0
    nominal, peer = told(fov, span, kind, err, 0)
    assert peer is None  # tetra3rs: its database's range, no estimate
    assert tolerance in FOV_TOLERANCE
    assert nominal * (1 - tolerance) == pytest.approx(fov / span)
    assert nominal * (1 + tolerance) == pytest.approx(fov * span)


def test_paths_cover_every_setting_once():
    rows = paths(1.7)
    labels = [r[0] for r in rows]
    assert len(labels) == len(set(labels))
    assert [r[3] for r in rows if r[1] == "fov" and r[2] == 0.025] == [0.0, 2.5, 4.0]
    assert ("FOV exact", "fov", 0.0, 0.0) in rows
    assert {r[1] for r in rows} == {"fov", "range", "blind", "junk"}


def test_fov_rows_tell_both_solvers_the_same_estimate():
    for i in range(4):
        ours, peer = told(20.0, 1.7, "fov", 4.0, i)
        assert ours == peer
        assert abs(ours - 20.0) == pytest.approx(0.8)
    assert told(20.0, 1.7, "blind", None, 0) == (None, None)


def test_any_answer_on_junk_is_wrong_and_no_answer_is_neither():
    camera = Camera.from_fov(640, 480, 20.0)
    junk = junk_frames(camera, 2, seed=1)
    assert len(junk) == 2 and len(junk[0].obs) == 40
    assert not np.allclose(junk[0].obs.x, junk[1].obs.x)
    assert score(None, junk[0], None, camera) == (False, False)
    assert score(("rotation", [], []), junk[0], None, camera) == (True, True)


def test_table_gives_the_ratio_to_each_peer_and_dashes_for_a_missing_one():
    row = {"fov": "20", "path": "FOV exact", "frames": 10, "startrack_solved": 10,
           "startrack_wrong": 0, "startrack_ms": 0.3, "tetra3rs_solved": 9,
           "tetra3rs_wrong": 0, "tetra3rs_ms": 0.2, "cedar-solve_solved": 10,
           "cedar-solve_wrong": 0, "cedar-solve_ms": 0.6}
    no_cedar = {k: v for k, v in row.items() if not k.startswith("cedar-solve")}
    alone = {k: v for k, v in no_cedar.items() if not k.startswith("tetra3rs")}
    lines = table([row, no_cedar, alone], ["tetra3rs", "cedar-solve"]).splitlines()
    assert "startrack / tetra3rs | startrack / cedar-solve |" in lines[0]
    assert lines[2].endswith("| 0.600 | 1.50x | 0.50x |")
    assert lines[3].endswith("| - | - | - | 1.50x | - |")
    assert lines[4].endswith("| - | - | - | - | - | - | - | - |")
    assert math.isclose(float(lines[2].split("|")[6]), 0.3)


@pytest.mark.parametrize("order", ["batch", "interleaved"])
def test_every_frame_is_solved_once_by_every_solver(order):
    names = ["startrack", "tetra3rs", "cedar-solve"]
    for turn in range(4):
        got = solve_order(5, names, order, turn)
        assert sorted(got) == sorted((i, n) for i in range(5) for n in names)


def test_batch_order_runs_one_solver_through_the_row_and_rotates_who_goes_first():
    names = ["startrack", "tetra3rs"]
    first = solve_order(3, names, "batch", 0)
    assert [n for _, n in first] == ["startrack"] * 3 + ["tetra3rs"] * 3
    assert [i for i, _ in first][:3] == [0, 1, 2]
    assert [n for _, n in solve_order(3, names, "batch", 1)][0] == "tetra3rs"
    interleaved = solve_order(2, names, "interleaved")
    assert interleaved == [(0, "startrack"), (0, "tetra3rs"), (1, "startrack"),
                           (1, "tetra3rs")]


def test_each_order_and_set_of_peers_writes_its_own_doc_section():
    assert doc_marker("batch", DEFAULT_PEERS) == "bench_paths"
    assert doc_marker("interleaved", list(DEFAULT_PEERS)) == "bench_paths interleaved"
    assert doc_marker("interleaved", ["tetra3rs", "cedar-solve"]) == \
        "bench_paths interleaved with tetra3rs,cedar-solve"
    assert doc_marker("batch", ["tetra3rs", "astrometry.net"]) == \
        "bench_paths with tetra3rs,astrometry.net"


def test_a_table_has_a_column_group_for_each_peer_run():
    row = {"fov": "20", "path": "FOV exact", "frames": 5, "startrack_solved": 5,
           "startrack_wrong": 0, "startrack_ms": 0.3, "astrometry.net_solved": 5,
           "astrometry.net_wrong": 0, "astrometry.net_ms": 600.0}
    head, _, body = table([row], ["astrometry.net"]).splitlines()
    assert "astrometry.net median ms" in head and "cedar-solve" not in head
    assert body.endswith("| 600.000 | 0.00x |")
