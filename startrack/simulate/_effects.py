"""Every optics, colour, detector and environment effect of a simulated frame, as one value.

A config's [optics], [band], [detector] and [environment] tables (docs/simulation.md) give an
:class:`Effects`; all of them off (the default) renders exactly today's frames.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from startrack.simulate._colour import Band
from startrack.simulate._detector import Detector
from startrack.simulate._effect_table import changed, table_from_dict
from startrack.simulate._environment import Environment
from startrack.simulate._optics import Optics

#: config tables -> the effect table each holds
TABLES = {"optics": Optics, "band": Band, "detector": Detector, "environment": Environment}


@dataclass(frozen=True)
class Effects:
    optics: Optics = field(default_factory=Optics)
    band: Band = field(default_factory=Band)
    detector: Detector = field(default_factory=Detector)
    environment: Environment = field(default_factory=Environment)

    @property
    def is_off(self) -> bool:
        return all(getattr(self, name).is_off for name in TABLES)

    def to_dict(self) -> dict:
        """The effects that are on, by table (empty when all are off)."""
        out = {name: changed(getattr(self, name)) for name in TABLES}
        return {k: v for k, v in out.items() if v}

    def with_levels(self, *, cosmic_rays: float | None = None,
                    stray_light: float | None = None,
                    temperature_c: float | None = None) -> Effects:
        """These effects with a compare condition's levels in place of the config's."""
        env, det = self.environment, self.detector
        if cosmic_rays is not None:
            env = dataclasses.replace(env, cosmic_rays=cosmic_rays)
        if stray_light is not None:
            env = dataclasses.replace(env, stray_light=stray_light)
        if temperature_c is not None:
            det = dataclasses.replace(det, temperature_c=temperature_c)
        return dataclasses.replace(self, environment=env, detector=det)


def effects_from_dict(data: dict, where: str = "config") -> Effects:
    """The effects of a config's tables (``data`` maps table name to table); missing
    tables are off."""
    return Effects(**{name: table_from_dict(cls, data[name], f"{where} [{name}]")
                      for name, cls in TABLES.items() if name in data})

__all__ = ["Effects", "TABLES", "effects_from_dict"]
