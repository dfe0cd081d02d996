"""docs/results.md from the papers' saved tables, and the helpers their scripts share.

Each paper's script saves its small tables (CSV) under ``docs/data/<section>/``, in the
repository, with a run record ``run.json`` beside them (command, commit, date, machine,
load). :func:`render` always builds the whole page from every section's saved tables, so
re-running one paper's script can never drop another's section; a section whose tables
are missing renders as "not run" and ``tests/papers/test_results_doc.py`` fails on it.
``python scripts/papers/_results_doc.py`` re-renders from the saved tables alone, and
``--check`` exits 1 naming any section that is missing, unstamped, made from uncommitted
changes or older than the last commit that changed startrack/ (the final regeneration's
test; the unit tests check only that each section is saved and stamped).
"""

from __future__ import annotations

import importlib
import json
import os
import shlex
import sys
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "out"
DATA = ROOT / "docs" / "data"
DOC = ROOT / "docs" / "results.md"
RUN_FILE = "run.json"
#: what a run record must name for its section to count as stamped
STAMP_KEYS = ("command", "git commit", "date (UTC)", "finished", "CPU")


@dataclass(frozen=True)
class Section:
    """One paper's section of docs/results.md: its saved tables live in
    ``docs/data/<slug>/``, ``script`` makes them, ``module.section(folder, run)`` (a
    module of scripts/papers/) renders them."""

    slug: str
    title: str
    script: str
    module: str

    @property
    def folder(self) -> Path:
        return DATA / self.slug


#: every section of the page, in its order; named after the papers, never numbered
SECTIONS = (
    Section("triangle-base-2011", "Automatic star identification using triangle base and "
            "increase search speed (2011)", "scripts/papers/paper2011.py",
            "scripts.papers._doc_triangle_base"),
    Section("radial-features", "An improved triangle star identification algorithm with "
            "radial features", "scripts/papers/radial_features.py",
            "scripts.papers._doc_radial_features"),
)


def section_by_slug(slug: str) -> Section:
    return next(s for s in SECTIONS if s.slug == slug)


def add_run_args(ap, name: str, slug: str | None = None) -> None:
    """The options the papers' scripts share: processes, resuming, where the scratch
    outputs go (``--out``, ignored by git) and where the saved tables go (``--data``)."""
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--resume", action="store_true",
                    help="finish an interrupted bench run in --out instead of starting over")
    ap.add_argument("--out", type=Path, default=OUT / name)
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    if slug is not None:
        ap.add_argument("--data", type=Path, default=DATA / slug,
                        help="where the section's small tables and run.json are saved")


def run_record(argv: list[str] | None, script: str) -> dict:
    """Where and how a run was made: the bench's provenance (commit with "+dirty", date,
    host, CPU, Python, libraries, command) and the load average at the start."""
    from startrack.bench import provenance

    args = sys.argv[1:] if argv is None else argv
    record = provenance(shlex.join([".venv/bin/python", script, *args]))
    return {**record, "load_start": [round(x, 2) for x in os.getloadavg()]}


def save_run(out: Path, record: dict, **extra) -> None:
    """Write the run record (finished now, with the load average at the end)."""
    record = {**record, **extra, "load_end": [round(x, 2) for x in os.getloadavg()],
              "finished": datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S")}
    out.mkdir(parents=True, exist_ok=True)
    (out / RUN_FILE).write_text(json.dumps(record, indent=1) + "\n")


def load_run(out: Path) -> dict | None:
    path = out / RUN_FILE
    return json.loads(path.read_text()) if path.exists() else None


def save_tables(folder: Path, record: dict, tables: dict[str, pd.DataFrame],
                **extra) -> None:
    """Save a section's tables as ``<name>.csv`` and then its run record (listing them):
    the record goes last, so a section is never stamped with tables it does not have."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, table in tables.items():
        # ten digits: a number typed from a paper (108.4258) comes back as typed
        table.to_csv(folder / f"{name}.csv", index=False, float_format="%.10g")
    save_run(folder, record, tables=sorted(tables), **extra)


def unstamped(folder: Path) -> str | None:
    """Why the section saved in ``folder`` does not count, None when it does: no run
    record, a record without command/commit/date, or a listed table missing."""
    run = load_run(folder)
    if run is None:
        return f"no {RUN_FILE} in {folder}"
    missing = [k for k in STAMP_KEYS if not run.get(k)]
    if missing:
        return f"{folder / RUN_FILE} lacks {', '.join(missing)}"
    absent = [t for t in run.get("tables", []) if not (folder / f"{t}.csv").exists()]
    if absent:
        return f"{folder} lacks the tables {', '.join(absent)} its {RUN_FILE} lists"
    return None


def saved_run(out: Path, run: dict | None, preset: str):
    """(table, config, arcsec per pixel) of a run saved under ``out`` with the preset
    ``configs/<preset>``; None when the run has not been made."""
    if run is None or not (out / "table.csv").exists():
        return None
    from startrack.simulate import load_config

    cfg = load_config(ROOT / "configs" / preset)
    return pd.read_csv(out / "table.csv"), cfg, float(np.degrees(1.0 / cfg.camera.f_px) * 3600.0)


def fmt_table(table: pd.DataFrame, columns: list[tuple[str, str, str | None]]) -> str:
    """A fixed-width text table of (header, column, format) triples; a missing column
    prints as '-', format None prints the value as it is."""
    show = {}
    for head, col, form in columns:
        if col not in table:
            show[head] = ["-"] * len(table)
        elif form is None:
            show[head] = table[col].astype(str)
        else:
            show[head] = table[col].map(lambda v, f=form: "-" if pd.isna(v) else f.format(v))
    return pd.DataFrame(show).to_string(index=False)


def plot_sweeps(table: pd.DataFrame, conditions, methods, panels, path: Path,
                title: str) -> None:
    """One column per swept variable, one row per quantity: ``panels`` is a list of rows,
    each a list of (column, style, label suffix) lines, with the row's y label first."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from startrack.bench import sweep

    variables = (("noise_px", "centroid noise (px, 1 sigma)"),
                 ("false_stars", "false stars per frame"))
    fig, axes = plt.subplots(len(panels), 2, figsize=(9, 3.1 * len(panels)), squeeze=False)
    for col, (var, label) in enumerate(variables):
        part = table[table["condition"].isin(sweep(list(conditions), var))]
        for row, (ylabel, lines) in enumerate(panels):
            ax = axes[row, col]
            for m in methods:
                r = part[part["method"] == m].sort_values(var)
                color = None
                for column, style, suffix in lines:
                    if column not in r:
                        continue
                    ax.plot(r[var], r[column], style, color=color, label=f"{m} {suffix}")
                    color = ax.lines[-1].get_color()
            ax.set_xlabel(label)
            ax.set_ylabel(ylabel)
            ax.set_ylim(bottom=-0.02)
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def variant_lines(table: pd.DataFrame, pairs: list[tuple[str, str, str]]) -> str:
    """One bullet per (ours, variant, what the variant changes) present in ``table``:
    raw wrong first hypotheses, verified correct and wrong, and the time ratio, summed or
    averaged over all conditions."""
    lines = []
    for ours, variant, what in pairs:
        a, b = (table[table["method"] == m] for m in (ours, variant))
        if a.empty or b.empty:
            continue

        def stats(r: pd.DataFrame) -> str:
            return (f"raw first hypothesis wrong in {int(r['first_wrong_frames'].sum())} of "
                    f"{int(r['raw_frames'].sum())} frames, none in "
                    f"{r['none_rate'].mean():.1%}; verified correct {r['correct_rate'].mean():.1%}"
                    f", {int(r['wrong'].sum())} wrong")

        ratio = (b["seq_ms_median"].to_numpy() / a["seq_ms_median"].to_numpy())
        lines.append(f"* `{variant}` ({what}) against `{ours}`, over all conditions: "
                     f"{stats(b)}, against {stats(a)}; median identify time "
                     f"{np.median(ratio):.2f} times `{ours}`'s (median over conditions)."
                     f"\n")
    return "".join(lines)


#: the options that set a paper script's run size (frames per condition of each pass)
SIZE_OPTIONS = ("frames", "raw_frames", "timing_frames", "fov_frames", "faint_frames",
                "label_frames")


def size_note(command: str) -> str:
    """Whether ``command`` (a paper script's, as its run record has it) ran at the
    script's full default size; when not, each smaller pass and its full size."""
    words = shlex.split(command)
    if len(words) < 2 or not words[1].endswith(".py"):
        return ""
    try:
        script = importlib.import_module(".".join(Path(words[1]).with_suffix("").parts))
    except ImportError:  # not a script of this checkout: nothing to compare with
        return ""
    given, full = script.parse_args(words[2:]), script.parse_args([])
    smaller = [f"`--{k.replace('_', '-')} {getattr(given, k)}` (full size "
               f"{getattr(full, k)})" for k in SIZE_OPTIONS
               if hasattr(full, k) and getattr(given, k) < getattr(full, k)]
    if not smaller:
        return "This is the full-size run.\n"
    return ("**This is not the full-size run**: " + ", ".join(smaller) + ", the largest "
            "that finished in the time the shared machine left (its load is in the stamp); "
            "`make results` runs the full size.\n")


def run_block(run: dict | None, name: str) -> str:
    """The lines that say how a section's tables were made."""
    if run is None:
        return f"*{name}: not run yet in this checkout (no {RUN_FILE}).*\n"
    load = ", ".join(f"{x:g}" for x in run["load_start"])
    load_end = ", ".join(f"{x:g}" for x in run.get("load_end", []))
    commit = str(run.get("git commit", run.get("commit", "?")))
    short = commit[:12] + ("+dirty" if commit.endswith("+dirty") else "")
    python = str(run.get("Python", run.get("python", "?"))).split()[0]
    return (f"Made by `{run['command']}` at commit `{short}`, "
            f"{run.get('date (UTC)', run.get('started'))} to {run.get('finished', '?')} UTC, "
            f"{run.get('wall_s', float('nan')):.0f} s wall, on {run.get('CPU', run.get('cpu'))}"
            f", load average {load} at the start and {load_end} at the end; Python {python}"
            f"{', ' + run['libraries'] if 'libraries' in run else ''}.\n\n"
            + size_note(run["command"]))


def render_section(section: Section) -> str:
    """The markdown of one section, from its saved tables (a note when not run)."""
    module = importlib.import_module(section.module)
    head = f"## {section.title}\n\n"
    if unstamped(section.folder) is not None:
        return head + run_block(None, section.script)
    return head + module.section(section.folder, load_run(section.folder))


def section_summary(section: Section) -> str:
    """A section's one-line summary for the README: its module's ``summary(folder, run)``
    when it has one, with the stamp; says so when the section is not saved."""
    why = unstamped(section.folder)
    if why is not None:
        return f"*{section.title}*: not run ({why})."
    run = load_run(section.folder)
    module = importlib.import_module(section.module)
    said = module.summary(section.folder, run) if hasattr(module, "summary") else (
        "see docs/results.md")
    commit = str(run["git commit"])
    return (f"*{section.title}*: {said}; made by `{run['command']}` at commit "
            f"`{commit[:12]}{'+dirty' if commit.endswith('+dirty') else ''}` on "
            f"{run['date (UTC)']} UTC.")


def render(doc: Path = DOC) -> Path:
    """Write docs/results.md from every section's saved tables."""
    from scripts.papers import _doc_papers, _verdicts

    parts = [_doc_papers.TITLE, _verdicts.RULES, _doc_papers.HEADER, _doc_papers.CLAIMS,
             *(render_section(s) for s in SECTIONS), _doc_papers.LIMITS]
    text = "\n".join(p.rstrip("\n") + "\n" for p in parts)
    tmp = doc.with_suffix(".md.tmp")
    tmp.write_text(text)
    tmp.replace(doc)
    return doc


def stale(folder: Path) -> str | None:
    """Why the saved section in ``folder`` is older than the code, None when it is not:
    made from uncommitted changes, or startrack/ changed in a commit after its own."""
    import subprocess

    commit = str(load_run(folder)["git commit"])
    if commit.endswith("+dirty"):
        return f"made from uncommitted changes at {commit[:12]}"
    log = subprocess.run(["git", "-C", str(ROOT), "log", "--oneline", f"{commit}..HEAD",
                          "--", "startrack/"], capture_output=True, text=True)
    if log.returncode != 0:
        return f"its commit {commit[:12]} is not in this checkout"
    changes = log.stdout.splitlines()
    return f"{len(changes)} commit(s) changed startrack/ since {commit[:12]}" if changes \
        else None


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if "--check" in args:
        problems = [f"{s.title}: {why}" for s in SECTIONS
                    if (why := unstamped(s.folder) or stale(s.folder)) is not None]
        for line in problems:
            print(line, file=sys.stderr)
        return 1 if problems else 0
    print(f"wrote {render()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
