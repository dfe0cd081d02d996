"""Astropy Quantities where the Python API takes degrees (docs/conventions.md, Python API).

Every angle keyword of :class:`startrack.Solver` takes a plain number (degrees) or an
astropy Quantity of any angular unit; a quantity of the wrong kind is an
:class:`~startrack.errors.InputValueError` naming the keyword.
"""

from __future__ import annotations

from startrack.errors import InputValueError

#: Solver keywords in degrees
DEGREE_KEYWORDS = ("fov_deg", "prior_sigma_deg", "ra", "dec", "radius")


def to_degrees(value, where: str):
    """``value`` in degrees: a number as it is, a Quantity converted (None stays None)."""
    if value is None or not hasattr(value, "unit"):
        return value
    from astropy import units as u  # astropy: only for a Quantity

    try:
        return float(value.to_value(u.deg))
    except (u.UnitsError, TypeError, ValueError):
        raise InputValueError(f"{where}: expected an angle, got {value!r}") from None


def scale_value(value, units: str, where: str) -> tuple[float | None, str]:
    """A scale bound and its ``scale_units``: a Quantity says its own units (an angle:
    ``degwidth``; angle per pixel: ``arcsecperpix``; a length: ``focalmm``)."""
    if value is None or not hasattr(value, "unit"):
        return value, units
    from astropy import units as u  # astropy: only for a Quantity

    for unit, name in ((u.deg, "degwidth"), (u.arcsec / u.pix, "arcsecperpix"),
                       (u.mm, "focalmm")):
        if value.unit.is_equivalent(unit):
            return float(value.to_value(unit)), name
    raise InputValueError(f"{where}: expected an angle, an angle per pixel or a focal "
                          f"length, got {value!r}")


def degree_options(options: dict) -> dict:
    """``options`` with every degree keyword (and ``prior``'s three angles) in degrees."""
    out = {k: to_degrees(v, k) if k in DEGREE_KEYWORDS else v for k, v in options.items()}
    if out.get("prior") is not None:
        try:
            out["prior"] = tuple(to_degrees(v, "prior") for v in out["prior"])
        except TypeError:
            raise InputValueError(f"prior: expected (ra, dec, roll), got "
                                  f"{out['prior']!r}") from None
    return out

__all__ = ["DEGREE_KEYWORDS", "degree_options", "scale_value", "to_degrees"]
