"""The base of the matchers that look pairs up among the pattern stars (angle, hybrid,
pyramid): their on-board catalog and the fainter stars they add when the brightest fail.
"""

from __future__ import annotations

from startrack.database import PairTable, StarDatabase
from startrack.match_records import Observation
from startrack.matchers._base import Matcher, MatcherConfig
from startrack.matchers._shared.pair_joins import pair_index


class PatternPairMatcher(Matcher):
    """A matcher whose pair lookups run in the pattern stars' pair table.

    Parameters
    ----------
    database : StarDatabase
        The catalog's pattern tables for one camera.
    config : MatcherConfig, optional
        The settings every matcher shares.
    pattern_per_region : int or None, default 15
        The on-board catalog of the pair lookups: the pattern stars, those with fewer than
        this many brighter stars within ``region_radius_deg`` (as the triangle table's);
        None: every catalog star.
    region_radius_deg : float or None, default None
        The pattern stars' region radius in degrees; None: half the field of view.
    extra_stars : int or None, default None
        When the ``config.max_stars`` brightest leave no answer (false stars crowd them),
        up to this many fainter stars join the next round; None: ``config.extra_stars``.
    """

    def __init__(self, database: StarDatabase, config: MatcherConfig | None = None, *,
                 pattern_per_region: int | None = 15, region_radius_deg: float | None = None,
                 extra_stars: int | None = None) -> None:
        super().__init__(database, config)
        self.pattern_per_region = None if pattern_per_region is None else int(pattern_per_region)
        self.region_radius_deg = region_radius_deg
        self.extra_stars = int(self.config.extra_stars if extra_stars is None else extra_stars)

    def _table(self) -> PairTable:
        return self.database.pattern_pairs(self.pattern_per_region, self.region_radius_deg)

    def _tables(self) -> list[PairTable]:
        """Every pair table the search may read (built by :meth:`prepare`)."""
        return [self._table()]

    def prepare(self) -> None:
        super().prepare()
        for table in self._tables():
            pair_index(table, len(self.database.vectors))

    def star_count(self, obs: Observation) -> int:
        """The stars a frame's search may use: the ``config.max_stars`` brightest and up to
        ``extra_stars`` fainter ones."""
        return min(self.config.max_stars + max(self.extra_stars, 0), len(obs))

__all__ = ["PatternPairMatcher"]
