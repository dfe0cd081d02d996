"""The files ``identify`` writes beside its answer: --annotate PNGs, --wcs headers and the
--corr table. With one input --annotate and --wcs name a file (or an existing folder to
write it in), with several a folder holding one file per input (named after the input),
or, given a file name with the option's suffix (``out/ann.png``), one file per input
beside it named after both (``out/ann_frame1.png``): never a folder named like a file.
Every file name is known before any work, and each is checked then
(:class:`startrack.io._writer.Writer`): an input inside that folder is never overwritten."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from startrack.errors import InputError
from startrack.io import Writer

SUFFIXES = {"annotate": ".png", "wcs": ".wcs"}


def unique_stems(names: list[str]) -> list[str]:
    """Each input's file stem, made unique within the batch (a.png, a.tiff -> a, a_2)."""
    counts: dict[str, int] = {}
    stems = []
    for name in names:
        stem = Path(name).stem or "input"
        counts[stem] = counts.get(stem, 0) + 1
        stems.append(stem if counts[stem] == 1 else f"{stem}_{counts[stem]}")
    return stems


@dataclass
class SideOutputs:
    """Where each side file goes, and the corr rows gathered so far."""

    writer: Writer
    inputs: list[str]
    annotate: Path | None = None
    wcs: Path | None = None
    corr: Path | None = None
    _corr_rows: list = field(default_factory=list)
    _targets: dict[str, dict[str, deque]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.inputs = [str(Path(name)) for name in self.inputs]  # as FrameResult.input
        several = len(self.inputs) > 1
        stems = unique_stems(self.inputs)
        for option in ("annotate", "wcs"):
            base = getattr(self, option)
            if base is None:
                continue
            base = Path(base)
            setattr(self, option, base)
            into_folder = several or base.is_dir()  # a link to a folder: written inside
            suffix = SUFFIXES[option]
            # several inputs and a file's name ("ann.png"): one file per input beside it
            beside = several and not base.is_dir() and base.suffix.lower() == suffix
            if several and not beside and base.exists() and not base.is_dir():
                raise InputError(f"--{option} {base}: with several inputs it names a folder "
                                 f"(or NAME{suffix}), and this exists as a file")
            targets = self._targets.setdefault(option, {})
            for name, stem in zip(self.inputs, stems, strict=True):
                path = (base.with_name(f"{base.stem}_{stem}{suffix}") if beside else
                        base / f"{stem}{suffix}" if into_folder else base)
                self.writer.check(path, f"--{option}")
                targets.setdefault(name, deque()).append(path)
        if self.corr is not None:
            self.corr = self.writer.check(self.corr, "--corr")

    @property
    def written(self) -> list[Path]:
        return self.writer.written

    def _target(self, option: str, name: str) -> Path:
        return self._targets[option][name].popleft()

    def add(self, frame) -> None:
        """Write one input's annotated PNG and WCS (when solved) and keep its corr rows."""
        if self.annotate is not None:
            from startrack.outputs._annotate import write_annotated  # astropy, matplotlib

            path = self._target("annotate", frame.input)
            with self.writer.path(path, "--annotate") as tmp:
                write_annotated(frame, tmp)
        if self.wcs is not None:
            path = self._target("wcs", frame.input)
            if frame.solution.solved:
                from startrack.outputs._wcs import solved_wcs_header, write_wcs  # astropy

                header = solved_wcs_header(frame)
                with self.writer.path(path, "--wcs") as tmp:
                    write_wcs(tmp, header)
        if self.corr is not None:
            from startrack.outputs._corr import corr_rows  # astropy (via the WCS)

            self._corr_rows.extend(corr_rows(frame))

    def finish(self) -> None:
        """Write the corr table (every input's rows, in input order)."""
        if self.corr is None:
            return
        from startrack.outputs._corr import write_corr  # astropy (via the WCS)

        with self.writer.path(self.corr, "--corr") as tmp:
            write_corr(tmp, self._corr_rows)
