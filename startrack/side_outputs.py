"""The files ``identify`` writes beside its answer: --annotate PNGs, --wcs headers and the
--corr table. With one input --annotate and --wcs name a file, with several a folder
holding one file per input (named after the input)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from startrack.errors import InputError

SUFFIXES = {"annotate": ".png", "wcs": ".wcs"}


def _check_target(path: Path, option: str, several: bool) -> None:
    if path.is_symlink() and not path.is_dir():
        # docs/conventions.md: an output that is not a regular file is never replaced
        raise InputError(f"--{option} {path}: is a symlink; give the file it points to")
    if several:
        if path.exists() and not path.is_dir():
            raise InputError(f"--{option} {path}: with several inputs it names a folder, "
                             "and this exists as a file")
    elif path.is_dir():
        return  # one input into an existing folder: the file goes inside it
    elif path.exists() and not path.is_file():
        raise InputError(f"--{option} {path}: exists and is not a regular file")


@dataclass
class SideOutputs:
    """Where each side file goes, and the corr rows gathered so far."""

    annotate: Path | None = None
    wcs: Path | None = None
    corr: Path | None = None
    several: bool = False
    written: list[Path] = field(default_factory=list)
    _corr_rows: list = field(default_factory=list)
    _stems: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for option in ("annotate", "wcs"):
            path = getattr(self, option)
            if path is not None:
                _check_target(Path(path), option, self.several)
                setattr(self, option, Path(path))
        if self.corr is not None:
            self.corr = Path(self.corr)
            if self.corr.is_dir():
                raise InputError(f"--corr {self.corr}: is a folder, expected a CSV file")
            _check_target(self.corr, "corr", several=False)

    @property
    def any(self) -> bool:
        return any(p is not None for p in (self.annotate, self.wcs, self.corr))

    def _target(self, option: str, base: Path, stem: str) -> Path:
        if self.several or base.is_dir():
            return base / f"{stem}{SUFFIXES[option]}"
        return base

    def _stem(self, name: str) -> str:
        """The input's file stem, made unique within the batch (a.png, a.tiff -> a, a_2)."""
        stem = Path(name).stem or "input"
        count = self._stems.get(stem, 0) + 1
        self._stems[stem] = count
        return stem if count == 1 else f"{stem}_{count}"

    def add(self, frame) -> None:
        """Write one input's annotated PNG and WCS (when solved) and keep its corr rows."""
        stem = self._stem(frame.input)
        if self.annotate is not None:
            from startrack.annotate import write_annotated

            path = self._target("annotate", self.annotate, stem)
            write_annotated(frame, path)
            self.written.append(path)
        if self.wcs is not None and frame.solution.solved:
            from startrack.wcs import solved_wcs_header, write_wcs

            path = self._target("wcs", self.wcs, stem)
            header = solved_wcs_header(frame)
            write_wcs(path, header)
            self.written.append(path)
        if self.corr is not None:
            from startrack.corr import corr_rows

            self._corr_rows.extend(corr_rows(frame))

    def finish(self) -> None:
        """Write the corr table (every input's rows, in input order)."""
        if self.corr is None:
            return
        from startrack.corr import write_corr

        write_corr(self.corr, self._corr_rows)
        self.written.append(self.corr)
