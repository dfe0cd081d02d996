"""Which sky a frame was made with (kind, size, seed, magnitude cut, epoch, file): the
record that sidecars, presets and run files carry, so that a catalog can be rebuilt
exactly. The catalogs themselves are ``startrack.sky``'s."""

from __future__ import annotations

from dataclasses import dataclass, fields

from startrack.errors import InputError
from startrack.input_checks import EPOCH_YEAR, MAG_LIMIT, check_keys, check_number

SKY_KINDS = ("random", "hipparcos", "gaia", "tycho2")
#: the kind of a user's catalog file (``--sky FILE``): its path is the spec's ``path``
FILE_KIND = "file"


@dataclass(frozen=True)
class SkySpec:
    """Everything needed to rebuild a catalog exactly; written into frame sidecars."""

    kind: str = "random"
    n_stars: int = 2000
    seed: int = 0
    mag_limit: float | None = None
    epoch: float | None = None  # Julian year for proper motion (Hipparcos and Gaia)
    # Closer stars are merged into the brighter one. None: two pixels of the camera the
    # sky is loaded for (the optics cannot split them), or no merging without a camera.
    min_separation_deg: float | None = None
    path: str | None = None  # the catalog file of a "file" sky (absolute)

    def to_dict(self) -> dict:
        # every field is a scalar: no deep copy (asdict's cost a record ~20 us a frame)
        data = {name: getattr(self, name) for name in _FIELDS}
        if data["path"] is None:  # the skies without a file keep their sidecar keys
            del data["path"]
        return data

    @classmethod
    def from_dict(cls, data: dict, where: str = "sky") -> SkySpec:
        """A spec from a config table or sidecar; unknown keys and bad values are errors."""
        check_keys(data, cls.__dataclass_fields__, where)
        kind = data.get("kind", "random")
        if kind not in (*SKY_KINDS, FILE_KIND):
            raise InputError(f"{where}: kind must be one of {', '.join(SKY_KINDS)}, "
                             f"or {FILE_KIND} with a path")
        if (kind == FILE_KIND) != isinstance(data.get("path"), str):
            raise InputError(f"{where}: path (a string) goes with kind {FILE_KIND} only")
        rules = {"n_stars": dict(integer=True, low=1), "seed": dict(integer=True, low=0),
                 "mag_limit": dict(bounds=MAG_LIMIT), "epoch": dict(bounds=EPOCH_YEAR),
                 "min_separation_deg": dict(low=0)}
        for key, rule in rules.items():
            if data.get(key) is not None:
                check_number(data[key], f"{where}: {key}", **rule)
        return cls(**data)


_FIELDS = tuple(f.name for f in fields(SkySpec))

__all__ = ["FILE_KIND", "SKY_KINDS", "SkySpec"]
