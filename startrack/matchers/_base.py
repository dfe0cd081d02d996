"""The matcher interface: observed stars in, correspondence hypotheses out.

A matcher proposes hypotheses (which observed star is which catalog star), best first;
it does not decide. The shared verification in :mod:`startrack.verify._verification` accepts or
refuses each one, so every method is held to the same standard of proof.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._shared.pair_joins import pair_index


@dataclass(frozen=True)
class MatcherConfig:
    """Settings every matcher shares.

    ``max_stars``: how many of the brightest observed stars the matcher may use (the
    2011 paper uses five). ``extra_stars``: fainter stars the matchers that can (angle,
    hybrid, pyramid) add when patterns of the ``max_stars`` brightest all fail, as when
    false stars crowd them; 0 keeps to the brightest (the paper's experiment).
    ``tolerance_sigma``: the half-width of every feature window in
    standard deviations of the propagated centroid noise. ``min_tolerance_rad``: a floor
    on angular windows, for noise-free input and unmodelled error (catalog, optics).
    """

    max_stars: int = 8
    extra_stars: int = 4
    tolerance_sigma: float = 4.0
    min_tolerance_rad: float = 5e-6


class Matcher(ABC):
    """A star-identification method: subclasses set ``name`` and implement
    :meth:`hypotheses`; :func:`register` makes one available by its name.

    A matcher proposes, the shared verification decides: every hypothesis it yields is
    held to the same evidence before an attitude is reported.

    Parameters
    ----------
    database : StarDatabase
        The catalog's pattern tables for one camera (:class:`startrack.database.StarDatabase`).
    config : MatcherConfig, optional
        The settings every matcher shares (default ``MatcherConfig()``).

    Raises
    ------
    TypeError
        Instantiating a subclass that does not implement :meth:`hypotheses`.

    Examples
    --------
    The smallest complete matcher: it proposes that the first three stars seen are
    catalog rows 0, 1 and 2 (verification would refuse that, as it should).

    >>> import numpy as np
    >>> from startrack.camera import Camera
    >>> from startrack.database import StarDatabase
    >>> from startrack.matchers import Matcher
    >>> from startrack.sky import load_sky
    >>> from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
    >>> class FirstThree(Matcher):
    ...     name = "doc-first-three"
    ...     def hypotheses(self, obs, diag, screen_rad=None):
    ...         diag.hypotheses += 1
    ...         yield Hypothesis(np.arange(3), np.arange(3))
    >>> camera = Camera.from_fov(640, 480, 15.0)
    >>> matcher = FirstThree(StarDatabase(load_sky("random", camera), camera))
    >>> obs = Observation.from_pixels(np.array([10.0, 200.0, 300.0]),
    ...                               np.array([5.0, 90.0, 400.0]), camera, 0.5)
    >>> diag = MatchDiagnostics()
    >>> [h.cat_index.tolist() for h in matcher.hypotheses(obs, diag)], diag.hypotheses
    ([[0, 1, 2]], 1)
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""
    #: StarDatabase tables the method reads; :meth:`prepare` loads them before timing.
    tables: ClassVar[tuple[str, ...]] = ("pairs",)
    #: whether the method finds the scale itself: with a nominal FOV the focal-length search
    #: (which such a method serves) then runs at once, without a first try at the nominal
    scale_free: ClassVar[bool] = False
    #: whether the search runs over the ``config.max_stars`` brightest stars (then
    #: ``extra_stars`` fainter ones): a nominal FOV's first look
    #: (:attr:`startrack.solver._identifier.Identifier.first_look`) narrows it to a few; a
    #: peer solves its own way, with its own settings
    brightest_first: ClassVar[bool] = True

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None) -> None:
        self.database = database
        self.config = config or MatcherConfig()

    def prepare(self) -> None:
        """Build or load the database tables this method needs (before any timing)."""
        for table in self.tables:
            loaded = getattr(self.database, table)
            if table == "pairs":  # the compiled joins' neighbour lists, built once
                pair_index(loaded, len(self.database.vectors))

    @abstractmethod
    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        """Yield hypotheses, most promising first; yield nothing when there is no match.

        ``screen_rad``: the match radius (radians) of verification's first test, when the
        caller verifies with it (:func:`startrack.solver._lost_in_space.identify` does). A
        matcher may then drop the hypotheses that test would refuse (the compiled
        ``fits_within`` of ``startrack/_core/verify/verification.pxd``) instead of handing
        them over one by one: the angle matcher does, inside its compiled search. None:
        every hypothesis is handed over."""

    def angle_tolerance(self, obs: Observation) -> float:
        """Half-width of an inter-star angle window: the angle between two centroids has a
        standard deviation of about sqrt(2) * sigma."""
        return max(self.config.tolerance_sigma * np.sqrt(2.0) * obs.sigma_rad,
                   self.config.min_tolerance_rad)


_REGISTRY: dict[str, type[Matcher]] = {}


def register(cls: type[Matcher]) -> type[Matcher]:
    """Class decorator: make a matcher available by its ``name`` (``--method NAME``,
    ``Solver(method=NAME)``). Other packages register theirs through the
    ``startrack.matchers`` entry point group (docs/conventions.md).

    Parameters
    ----------
    cls : type
        A :class:`Matcher` subclass with a ``name``.

    Returns
    -------
    type
        ``cls`` itself, registered.

    Raises
    ------
    ValueError
        Another class is already registered under ``cls.name``.

    Examples
    --------
    >>> import numpy as np
    >>> import startrack
    >>> from startrack.matchers import Matcher, get_matcher, register
    >>> @register
    ... class Nothing(Matcher):
    ...     name = "doc-nothing"
    ...     def hypotheses(self, obs, diag, screen_rad=None):
    ...         return iter(())
    >>> get_matcher("doc-nothing") is Nothing
    True
    >>> startrack.solve(np.array([[10.0, 20.0], [30.0, 40.0], [500.0, 600.0]]),
    ...                 fov_deg=20.0, size=(1024, 1024), sky="random",
    ...                 method="doc-nothing").reason
    'no_match'
    >>> class Other(Nothing):
    ...     pass
    >>> register(Other)
    Traceback (most recent call last):
    ValueError: matcher 'doc-nothing' registered twice
    """
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise ValueError(f"matcher {cls.name!r} registered twice")
    _REGISTRY[cls.name] = cls
    return cls


def registry() -> dict[str, type[Matcher]]:
    return dict(_REGISTRY)


def register_variant(base: type[Matcher], name: str, description: str,
                     **preset) -> type[Matcher]:
    """Register ``base`` under ``name`` with other constructor defaults (any keyword still
    overrides them): a paper-literal variant, run side by side with the method it varies
    (``variant_of``) and, being weaker by design, not held to the matcher contract."""
    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None,
                 **kwargs) -> None:
        base.__init__(self, database, config, **{**preset, **kwargs})

    cls = type(f"{base.__name__}_{name}", (base,), {
        "name": name, "description": description, "__init__": __init__,
        "variant_of": base.name, "__doc__": f"{description}: {base.__name__} with {preset}."})
    return register(cls)

__all__ = ["Matcher", "MatcherConfig", "register", "register_variant", "registry"]
