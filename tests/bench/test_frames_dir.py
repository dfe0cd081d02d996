"""compare --frames-dir: the methods on a folder of frames with their truth, as simulate
writes it, give the same rates as the generated run on the same frames."""

from __future__ import annotations

import pandas as pd
from click.testing import CliRunner

from startrack.bench._conditions import Condition
from startrack.bench._frames_dir import export_frames
from startrack.bench._runner import RunSpec, bench_frame
from startrack.bench._session import run_comparison
from startrack.cli import main
from startrack.simulate import DEFAULT_CONFIG, config_from_dict
from startrack.sky import resolve_sky

FRAMES = 16
METHODS = ("angle", "pyramid")


def _spec() -> RunSpec:
    cfg = config_from_dict(DEFAULT_CONFIG, "default config")
    # 0.5 px: the sigma identify assumes for a centroid list (DEFAULT_SIGMA_PX), so the
    # folder's frames are identified with the generated run's tolerances
    return RunSpec(methods=METHODS, conditions=(Condition(noise_px=0.5, false_stars=2),),
                   frames=FRAMES, seed=5, camera=cfg.camera,
                   sky=resolve_sky(cfg.sky, cfg.camera), max_stars=5)


def test_frames_dir_gives_the_generated_runs_rates(tmp_path):
    spec = _spec()
    generated = run_comparison(spec, tmp_path / "gen", jobs=1)
    frames = [(f, bench_frame(spec, 0, f)[2]) for f in range(FRAMES)]
    bench = bench_frame(spec, 0, 0)[0]
    catalog = bench.identifiers[METHODS[0]].catalog
    export_frames(frames, catalog, spec.sky, spec.conditions[0], tmp_path / "folder")

    result = CliRunner().invoke(main, ["compare", "--frames-dir", str(tmp_path / "folder"),
                                       "--methods", ",".join(METHODS), "--max-stars", "5",
                                       "-q", "--out", str(tmp_path / "dir")])
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    assert "pyramid" in result.stdout and (tmp_path / "dir" / "report.md").is_file()
    ours = pd.read_csv(tmp_path / "dir" / "summary.csv").set_index("method")
    theirs = generated.summary.set_index("method")
    for column in ("frames", "solved_rate", "correct_rate", "wrong_rate", "star_precision"):
        assert (ours[column] == theirs[column]).all(), column
    assert (ours["correct_rate"] > 0.5).all()
    per_frame = pd.read_csv(tmp_path / "dir" / "frames.csv")
    gen_frames = pd.read_csv(generated.frames_csv)
    key = ["frame", "method"]
    merged = per_frame.merge(gen_frames, on=key, suffixes=("", "_gen"))
    assert len(merged) == FRAMES * len(METHODS)
    for column in ("solved", "correct", "n_identified", "n_id_correct"):
        assert (merged[column] == merged[f"{column}_gen"]).all(), column


def test_frames_dir_runs_on_simulate_output_and_bad_folders_are_one_line(tmp_path):
    sim = CliRunner().invoke(main, ["simulate", "--frames", "3", "--out", str(tmp_path / "s"),
                                    "-q"])
    assert sim.exit_code == 0, sim.output
    result = CliRunner().invoke(main, ["compare", "--frames-dir", str(tmp_path / "s"),
                                       "--methods", "pyramid", "-q",
                                       "--out", str(tmp_path / "c")])
    assert result.exit_code == 0, result.output
    summary = pd.read_csv(tmp_path / "c" / "summary.csv")
    assert summary["frames"].tolist() == [3] and summary["wrong_rate"].tolist() == [0]
    assert summary["correct_rate"].iloc[0] >= 2 / 3  # rendered frames, extracted centroids

    (tmp_path / "empty").mkdir()
    bad = CliRunner().invoke(main, ["compare", "--frames-dir", str(tmp_path / "empty"),
                                    "--out", str(tmp_path / "c2")])
    assert bad.exit_code == 2
    assert bad.stderr.count("\n") == 1 and "truth.csv is missing" in bad.stderr
