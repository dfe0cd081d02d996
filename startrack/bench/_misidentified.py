"""Misidentified stars per image, the improved triangle paper's own measure (its Figures 5
and 6): every star of a bench frame labelled by a radial-family matcher
(:func:`startrack.bench._star_labels.label_every_star`), scored against the truth."""

from __future__ import annotations

import time

import pandas as pd

from startrack.bench._raw import map_units
from startrack.bench._runner import RunSpec, bench_frame, point_patch
from startrack.bench._star_labels import label_every_star, score_labels

DEFAULT_NEIGHBOURS = 4


def label_unit(spec: RunSpec, condition_index: int, frame: int, *,
               neighbours: int = DEFAULT_NEIGHBOURS) -> list[dict]:
    """Frame ``frame`` of condition ``condition_index`` through every method of ``spec``
    (each a radial matcher or variant): one row per method with the image's counts
    (:func:`~startrack.bench._star_labels.score_labels`) and ``label_ms``."""
    bench, condition, bf = bench_frame(spec, condition_index, frame)
    rows = []
    for name in spec.methods:
        matcher = bench.identifier(name, bf.obs.camera).matcher
        point_patch(matcher, bf)
        t0 = time.perf_counter()
        labels = label_every_star(matcher, bf.obs, neighbours)
        ms = (time.perf_counter() - t0) * 1000.0
        rows.append({"condition": condition_index, **condition.to_dict(), "frame": frame,
                     "method": name, **score_labels(labels, bf.truth_rows), "label_ms": ms})
    return rows


def label_pass(spec: RunSpec, frames: int, *, neighbours: int = DEFAULT_NEIGHBOURS,
               jobs: int = 1) -> pd.DataFrame:
    """:func:`label_unit` over the first ``frames`` frames of every condition."""
    return map_units(label_unit, spec, frames, jobs=jobs, neighbours=neighbours)

__all__ = [
    "label_pass", "label_unit",
]
