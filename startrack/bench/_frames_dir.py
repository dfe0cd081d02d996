"""``compare --frames-dir``: every method on a folder of the user's own frames (images or
centroid CSVs), scored against the folder's truth in the format ``simulate`` writes:
``truth.csv`` (frame, file, true quaternion), ``stars.csv`` (the stars drawn in each
frame, false ones with catalog_id -1) and a sidecar JSON per frame (camera and sky).

The frames are read once; each method identifies each frame's centroids with the
sidecar's camera and sky, and is scored like a generated run (a spot within
``TRUTH_RADIUS_PX`` of a drawn star is that star), so the tables, report.md and
frames.csv are the same as ``compare`` writes.
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.bench._conditions import Condition
from startrack.bench._frames import BenchFrame, label_spots
from startrack.bench._frames_truth import check_agreement, check_stars, check_truth
from startrack.camera import Camera
from startrack.errors import InputError
from startrack.io import STARS_COLUMNS, TRUTH_COLUMNS, read_sidecar, sidecar_path_for
from startrack.sky import SkySpec


@dataclass(frozen=True)
class FramesFolder:
    """A folder of frames with their truth: one camera and sky for every frame."""

    folder: Path
    camera: Camera
    sky: SkySpec
    condition: Condition  # the folder's frames options (sidecar "frames"), for the tables
    truth: pd.DataFrame  # truth.csv
    stars: pd.DataFrame  # stars.csv


def _read_csv(path: Path, columns: list[str], numeric: list[str]) -> pd.DataFrame:
    """``path`` with ``columns``, each row's ``numeric`` ones finite numbers."""
    try:
        table = pd.read_csv(path)
    except FileNotFoundError:
        raise InputError(f"--frames-dir: {path} is missing (a folder needs truth.csv, "
                         "stars.csv and a sidecar JSON per frame, as simulate writes)") \
            from None
    except (OSError, ValueError) as exc:
        raise InputError(f"--frames-dir: {path}: cannot read ({exc})") from None
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(f"--frames-dir: {path}: missing column(s) {', '.join(missing)}")
    # A junk row was read as a frame named by its second field ("row.json: cannot read")
    values = table[numeric].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if len(bad):
        raise InputError(f"--frames-dir: {path}: line {int(bad[0]) + 2}: "
                         f"{', '.join(numeric)} must be finite numbers")
    return table


def read_frames_folder(folder: str | Path) -> FramesFolder:
    """The folder's truth, stars and the camera and sky its sidecars share."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"--frames-dir: {folder}: not a folder")
    truth = _read_csv(folder / "truth.csv", TRUTH_COLUMNS[:6], ["frame", *TRUTH_COLUMNS[2:6]])
    stars = _read_csv(folder / "stars.csv", STARS_COLUMNS, ["frame", "x", "y"])
    if truth.empty:
        raise InputError(f"--frames-dir: {folder / 'truth.csv'} lists no frame")
    first = None
    for name in truth["file"]:
        camera, sky, _ = read_sidecar(sidecar_path_for(folder / str(name)))
        if first is None:
            first = (camera, sky, sidecar_path_for(folder / str(name)))
        elif (camera, sky) != first[:2]:
            raise InputError(f"--frames-dir: {name}'s sidecar gives another camera or sky "
                             f"than {first[2].name}; a folder is one camera and one sky")
    truth = check_truth(folder, truth)
    stars = check_stars(folder, stars, truth)
    return FramesFolder(folder, first[0], first[1], _condition(first[2]), truth, stars)


def _condition(sidecar: Path) -> Condition:
    """The frames options a sidecar records (its "frames" entry), checked."""
    from startrack.input_checks import FALSE_STARS, FRACTION, MAG_NOISE, check_number

    options = json.loads(sidecar.read_text()).get("frames") or {}
    if not isinstance(options, dict):
        raise InputError(f"--frames-dir: {sidecar}: 'frames' must be an object")
    values = {}
    for key, check, default in (("false_stars", FALSE_STARS, 0), ("missing", FRACTION, 0.0),
                                ("mag_noise", MAG_NOISE, 0.0)):
        value = options.get(key)
        values[key] = default if value is None else check_number(
            value, f"--frames-dir: {sidecar}: frames.{key}", check)
    return Condition(**values)


def _bench_frame(data: FramesFolder, row, catalog, identifier) -> tuple[int, BenchFrame]:
    """Frame ``row`` of truth.csv read (centroids extracted from an image) and labelled
    with the catalog rows of the stars drawn in it."""
    from startrack.attitude import from_quaternion
    from startrack.solver import read_input

    index = int(row.frame)
    frame = read_input(data.folder / str(row.file))
    obs = identifier.observation(frame.centroids)
    drawn = data.stars[data.stars["frame"] == index]
    ids = drawn["catalog_id"].to_numpy(dtype=np.int64)  # exact (check_stars)
    rows = catalog.index_of(ids)  # -1: a false star or an unknown id
    rows[drawn["is_false"].to_numpy() | (ids < 0)] = -1
    truth = label_spots(obs.x, obs.y, drawn["x"].to_numpy(), drawn["y"].to_numpy(), rows)
    rotation = from_quaternion(np.array([row.qw, row.qx, row.qy, row.qz], dtype=float))
    return index, BenchFrame(obs, truth, rotation, int(np.count_nonzero(rows >= 0)),
                             frame.centroid_ms)


def warm_up(data: FramesFolder, catalog, identifiers: dict) -> None:
    """Read the first frame once untimed (its reader imported, an image's extraction
    warmed) and solve it with every method (the paths a real frame takes, its fluxes
    checked, beyond the throwaway frame each identifier solved when it was made), so the
    first timed frame pays no one-time cost."""
    first = next(data.truth.itertuples(index=False))
    _, bf = _bench_frame(data, first, catalog, next(iter(identifiers.values())))
    for identifier in identifiers.values():
        identifier.identify(bf.obs)


def checked_sky(data: FramesFolder):
    """The folder's sky, once its truth is found to agree with its stars.csv
    (startrack.bench._frames_truth): (catalog, seconds it took to load)."""
    from startrack.sky import load_sky

    t0 = time.perf_counter()
    catalog = load_sky(data.sky, data.camera)
    seconds = time.perf_counter() - t0
    check_agreement(data.folder, data.truth, data.stars, catalog, data.camera)
    return catalog, seconds


def run_frames_folder(data: FramesFolder, methods: tuple[str, ...], *, max_stars: int,
                      threshold_arcsec: float, quiet: bool = False, sky=None):
    """Every method on every frame of the folder: (frames.csv rows, load seconds);
    ``sky``: :func:`checked_sky`'s answer, when already loaded."""
    from startrack.bench._runner import frame_row
    from startrack.outputs import progress
    from startrack.solver import Identifier

    catalog, seconds = checked_sky(data) if sky is None else sky
    load = {"sky": seconds}
    identifiers = {}
    for name in methods:
        identifiers[name] = Identifier(data.camera, catalog, name, max_stars=max_stars)
        load[name] = identifiers[name].load_seconds
    warm_up(data, catalog, identifiers)
    counter = progress(len(data.truth), desc="compare", unit="frame", quiet=quiet)
    rows = []
    try:
        for row in data.truth.itertuples(index=False):
            index, bf = _bench_frame(data, row, catalog, identifiers[methods[0]])
            for name in methods:
                solution = identifiers[name].identify(bf.obs)
                rows.append(frame_row(0, data.condition, index, name, solution, bf,
                                      threshold_arcsec))
            counter.update(1)
    finally:
        counter.close()
    return rows, load


def export_frames(bench_frames: list[tuple[int, BenchFrame]], catalog, sky: SkySpec,
                  condition: Condition, folder: Path) -> None:
    """Write bench frames as a folder ``--frames-dir`` reads: a centroid CSV and a sidecar
    per frame, truth.csv and stars.csv (the observed stars, false ones with id -1)."""
    from startrack.attitude import to_quaternion, to_radec_roll
    from startrack.centroids import Centroids, write_centroid_csv

    folder.mkdir(parents=True, exist_ok=True)
    truth_rows, star_rows = [], []
    for index, bf in bench_frames:
        name = f"frame_{index:04d}.csv"
        obs = bf.obs
        flux = obs.flux if obs.flux is not None else np.arange(len(obs.x), 0, -1.0)
        flux = flux * (1e6 / flux.max())  # CSV keeps 4 decimals: keep the brightness order
        write_centroid_csv(folder / name, Centroids(obs.x, obs.y, flux))
        q = [float(c) for c in to_quaternion(bf.rotation)]
        sidecar = {"camera": obs.camera.to_dict(), "sky": sky.to_dict(),
                   "attitude": {"quaternion": q}, "frames": {
                       "missing": condition.missing, "false_stars": condition.false_stars,
                       "mag_noise": condition.mag_noise}}
        sidecar_path_for(folder / name).write_text(json.dumps(sidecar, indent=2) + "\n")
        truth_rows.append([index, name, *q, *to_radec_roll(bf.rotation)])
        for k in range(len(obs.x)):
            real = bf.truth_rows[k] >= 0
            cid = int(catalog.ids[bf.truth_rows[k]]) if real else -1
            mag = float(catalog.mag[bf.truth_rows[k]]) if real else float("nan")
            star_rows.append([index, float(obs.x[k]), float(obs.y[k]), float(flux[k]), mag,
                              cid, int(not real)])
    for file, columns, rows in (("truth.csv", TRUTH_COLUMNS, truth_rows),
                                ("stars.csv", STARS_COLUMNS, star_rows)):
        with open(folder / file, "w", newline="") as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(columns)
            writer.writerows(rows)


def compare_frames_folder(folder: str | Path, methods: tuple[str, ...], out: str | Path, *,
                          max_stars: int, threshold_arcsec: float, quiet: bool = False,
                          announce=None, overwrite: bool = False, finish=None):
    """Run every method on the folder's frames into ``out`` (frames.csv, summary.csv,
    db.csv): a :class:`~startrack.bench._session.RunOutputs`. ``out`` is held as every
    compare holds its folder (startrack.io._run_folder); ``finish(result)`` writes report.md
    while it is held. ``out`` must not hold another run; the run is redone whole."""
    from startrack.bench._metrics import summarise
    from startrack.bench._report_run import frames_dir_description, machine_load
    from startrack.bench._runner import COLUMNS
    from startrack.bench._session import (
        DB_FILE,
        GROUP_COLUMNS,
        SUMMARY_FILE,
        RunOutputs,
        run_in_folder,
    )
    from startrack.bench._store import FRAMES_FILE, format_rows, run_identity
    from startrack.io import atomic_text

    t0, load_at_start = time.perf_counter(), machine_load()
    source = Path(folder)
    if Path(out).resolve() == source.resolve():
        raise InputError(f"--out {out}: is the --frames-dir folder; choose another --out")
    data = read_frames_folder(source)
    sky = checked_sky(data)  # a truth that disagrees is refused before --out is touched
    identity = run_identity({"frames_dir": str(source.resolve()), "methods": list(methods),
                             "max_stars": max_stars, "threshold_arcsec": threshold_arcsec})

    def run(out: Path):
        if announce is not None:
            announce(data)
        frames, load = run_frames_folder(data, methods, max_stars=max_stars,
                                         threshold_arcsec=threshold_arcsec, quiet=quiet,
                                         sky=sky)
        with atomic_text(out / FRAMES_FILE) as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(COLUMNS)
            writer.writerows(format_rows(frames, COLUMNS))
        summary = summarise(pd.read_csv(out / FRAMES_FILE), GROUP_COLUMNS)
        with atomic_text(out / SUMMARY_FILE) as fh:
            summary.to_csv(fh, index=False, float_format="%.6g", lineterminator="\n")
        with atomic_text(out / DB_FILE) as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["stage", "seconds"])
            w.writerows([stage if stage == "sky" else f"{stage} database+prepare",
                         f"{seconds:.4f}"] for stage, seconds in load.items())
        result = RunOutputs(out, out / FRAMES_FILE, out / SUMMARY_FILE, out / DB_FILE, [],
                            summary, len(data.truth), 0, load, time.perf_counter() - t0,
                            frames_dir_description(data, methods, max_stars,
                                                   threshold_arcsec), load_at_start)
        if finish is not None:
            finish(result)
        return result

    inputs = [p for p in source.iterdir() if p.is_file()]
    return run_in_folder(out, identity, run, resume=False, overwrite=overwrite, inputs=inputs)


def identify_command(folder: str | Path):
    """A function giving, for a frames.csv row of a ``--frames-dir`` run, the command that
    replays it: ``startrack identify FILE --method M`` (its sidecar is beside it)."""
    truth = pd.read_csv(Path(folder) / "truth.csv")
    files = {int(f): str(Path(folder) / str(n))
             for f, n in zip(truth["frame"], truth["file"], strict=True)}
    return lambda row: ["startrack", "identify", files[int(row["frame"])], "--method",
                        str(row["method"])]

__all__ = [
    "FramesFolder", "checked_sky", "compare_frames_folder", "export_frames", "identify_command",
    "read_frames_folder", "run_frames_folder",
]
