"""`startrack compare`'s other modes (``--frames-dir``, ``--mode tracking``, ``--replay``),
the folder a run without ``--out`` gets, and the lines a finished run prints."""

from __future__ import annotations

import contextlib
import datetime as dt
import os
from pathlib import Path

import click

from startrack.cli._compare_request import CompareRun
from startrack.defaults import DEFAULT_METHOD
from startrack.errors import InputError

#: where runs without --out go: one new folder each, ``latest`` pointing at the newest
RUNS_FOLDER = Path("out/compare")
LATEST = "latest"


def run_folder(out_dir: str | None, resume: bool | None, note=lambda text: None):
    """The run's folder and ``started()``, to call once the run holds it: ``--out`` as
    given; without it, ``--resume`` takes the run ``latest`` points at, else a new folder
    of :data:`RUNS_FOLDER` named after the time (UTC), so that two runs never meet in one
    folder, which ``started()`` names (``note``) and points ``latest`` at."""
    if out_dir is not None:
        return Path(out_dir), lambda: None
    latest = RUNS_FOLDER / LATEST
    if resume:
        if not latest.is_dir():
            raise InputError(f"--resume: no earlier run to resume ({latest} does not "
                             "exist); give --out FOLDER")
        folder = RUNS_FOLDER / os.readlink(latest) if latest.is_symlink() else latest
        return folder, lambda: note(f"compare: resuming {folder}/")
    stamp = dt.datetime.now(dt.UTC).strftime("%Y%m%d-%H%M%S")
    folder, k = RUNS_FOLDER / stamp, 2
    while os.path.lexists(folder):
        folder, k = RUNS_FOLDER / f"{stamp}-{k}", k + 1

    def started() -> None:
        point_latest(folder)
        note(f"compare: writing to {folder}/ ({latest} points at it)")
    return folder, started


def point_latest(folder: Path) -> None:
    """Make ``out/compare/latest`` point at ``folder`` (a relative link, replaced in one
    step); where links cannot be made, nothing (the run's folder is printed anyway)."""
    latest = folder.parent / LATEST
    tmp = folder.parent / f".{LATEST}.{os.getpid()}"
    with contextlib.suppress(OSError):
        if os.path.lexists(latest) and not latest.is_symlink():
            return  # a user's own file or folder named latest: left alone
        os.symlink(folder.name, tmp, target_is_directory=True)
        os.replace(tmp, latest)
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def report_writer(ctx, reports: list):
    """``finish(result, replay_for=None)``: writes report.md (while the run holds --out)
    and appends its path to ``reports``."""
    def finish(result, replay_for=None) -> None:
        from startrack.bench import NOT_REPLAYED, command_line, write_report

        reports.append(write_report(result, command_line(ctx),
                                    command_line(ctx, drop=NOT_REPLAYED), replay_for))
    return finish


def print_finished(result, report: Path) -> None:
    """Print the tables and where the files are (``report``: report.md, written)."""
    from startrack.bench import format_table

    click.echo(format_table(result.summary))
    loads = ", ".join(f"{k} {v:.2f} s" for k, v in result.load_seconds.items())
    click.echo(f"\nload (sky, database+prepare per method): {loads}")
    click.echo(f"wrote {report}, {result.frames_csv} (per frame), {result.summary_csv} "
               f"(per condition), {result.db_csv}, plots: "
               f"{', '.join(p.name for p in result.plots) or 'none (nothing swept)'} "
               f"in {result.out}/ ({result.wall_seconds:.1f} s)")


def frames_dir_run(run: CompareRun) -> None:
    """``--frames-dir``: every method on the folder's frames (startrack.bench's
    ``compare_frames_folder``), once the run holds its folder."""
    from startrack.bench import compare_frames_folder, identify_command

    folder, request = run.request.frames_dir, run.request

    def announce(data) -> None:
        run.started()
        run.note(f"compare: {', '.join(run.methods)} on {len(data.truth)} frame(s) of "
                 f"{folder}")

    try:
        result = compare_frames_folder(
            folder, run.methods, run.out_dir, max_stars=request.max_stars,
            threshold_arcsec=request.threshold_arcsec, quiet=request.quiet,
            announce=announce, overwrite=request.folder.overwrite,
            finish=lambda r: run.finish(r, identify_command(folder)))
    except InputError:
        raise
    except OSError as exc:
        raise InputError(f"--out {run.out_dir}: cannot write ({exc.strerror or exc})") \
            from None
    print_finished(result, run.reports[0])


def tracking_run(run: CompareRun, cfg, spec_sky, inputs: list) -> None:
    """``--mode tracking``: the options as given (unset ones take the tracking defaults)."""
    from click.core import ParameterSource

    from startrack.bench import (
        TRACKING_FRAMES,
        compare_tracking,
        markdown_table,
        parse_tracking_levels,
        run_identity,
        run_in_folder,
    )

    ctx, request, lv = click.get_current_context(), run.request, run.request.levels
    given = {n: ctx.get_parameter_source(n) == ParameterSource.COMMANDLINE
             for n in ("methods", "frames")}
    names = run.methods if given["methods"] else (DEFAULT_METHOD,)
    levels = parse_tracking_levels({"rate_dps": lv.rates, "noise_px": lv.noise_px,
                                    "false_stars": lv.false_stars, "missing": lv.missing})
    spec = dict(methods=names, levels=levels,
                frames=request.frames if given["frames"] else TRACKING_FRAMES,
                fps=request.fps, seed=cfg.frames.seed if request.seed is None
                else request.seed, threshold_arcsec=request.threshold_arcsec)
    identity = run_identity({"mode": "tracking", "camera": cfg.camera.to_dict(),
                             "sky": spec_sky.to_dict(), **spec})
    summary, _ = run_in_folder(run.out_dir, identity, lambda out: compare_tracking(
        cfg.camera, spec_sky, out=out, **spec, progress=run.note),
        resume=request.folder.resume, overwrite=request.folder.overwrite, inputs=inputs)
    click.echo(markdown_table(summary))
    click.echo(f"wrote frames.csv, summary.csv, time_ratio.csv, report.md and plots in "
               f"{run.out_dir}/")


def replay_one(spec, text: str) -> None:
    """Run one (condition, frame) unit of ``spec`` and print every method's answer."""
    from startrack.bench import condition_text, replay_text, run_unit

    try:
        condition, frame = (int(p) for p in text.split(","))
    except ValueError:
        raise InputError(f"--replay: expected CONDITION,FRAME (two integers), got {text!r}") \
            from None
    if not 0 <= condition < len(spec.conditions) or not 0 <= frame < spec.frames:
        raise InputError(f"--replay: this run has conditions 0..{len(spec.conditions) - 1} "
                         f"and frames 0..{spec.frames - 1}, got {text!r}")
    click.echo(f"condition {condition} ({condition_text(spec.conditions[condition].to_dict())}"
               f"), frame {frame}:")
    click.echo(replay_text(run_unit(spec, condition, frame)))
