"""The tracking bench on rendered frames: every run answers every frame, tracked runs
track after the first frame, lost-in-space runs never do, and the ratio is the medians'."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.bench._tracking_bench import TrackCondition
from startrack.bench._tracking_images import (
    FOV_CASES,
    rendered_sequence,
    run_images,
    summarise_images,
)
from startrack.simulate import SensorModel
from startrack.sky import SkySpec


@pytest.fixture(scope="module")
def hip_sky(hip_db):
    return SkySpec(kind="hipparcos", mag_limit=6.5), hip_db.catalog, hip_db.camera


def test_rendered_sequence_is_reproducible_and_moves(hip_sky):
    spec, catalog, camera = hip_sky
    a = list(rendered_sequence(catalog, camera, SensorModel(), TrackCondition(), 2, 10.0, 4))
    b = list(rendered_sequence(catalog, camera, SensorModel(), TrackCondition(), 2, 10.0, 4))
    assert all(np.array_equal(x[0], y[0]) for x, y in zip(a, b, strict=True))
    assert a[0][0].shape == (1024, 1024)
    turned = np.degrees((a[0][1].inv() * a[1][1]).magnitude())
    assert turned == pytest.approx(np.linalg.norm([1.0, 0.5, 2.0]) / 10.0, rel=1e-9)


def test_image_runs_track_after_the_first_frame_and_lost_in_space_never(hip_sky):
    spec, catalog, camera = hip_sky
    df = run_images(catalog, spec, camera, SensorModel(), TrackCondition(), 4, 10.0, 4)
    assert len(df) == 4 * 2 * len(FOV_CASES)
    assert df["solved"].all() and (df["error_arcsec"] < 60.0).all()
    for (_, run), g in df.groupby(["fov", "run"]):
        modes = g.sort_values("frame")["mode"].tolist()
        want = ["lost_in_space"] + ["tracking" if run == "track" else "lost_in_space"] * 3
        assert modes == want
    table = summarise_images(df).set_index(["fov", "run"])
    for fov, _ in FOV_CASES:
        lis = df[(df["fov"] == fov) & (df["run"] == "lost_in_space")]["identify_ms"].median()
        track = df[(df["fov"] == fov) & (df["run"] == "track")]["identify_ms"].median()
        assert table.loc[(fov, "track"), "lis_over_track"] == pytest.approx(lis / track)
        assert table.loc[(fov, "track"), "tracked"] == 3
