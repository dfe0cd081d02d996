"""Annual aberration: star directions as seen from the moving Earth, and the attitude fix.

A camera on the Earth sees each star displaced towards the Earth's direction of motion by
up to v/c ~ 20.5 arcsec. The catalog holds barycentric (ICRS) directions, so an attitude
solved against it is off by about that much. Given the observation time, the Earth's
barycentric velocity (astropy's ephemeris) turns catalog directions into apparent ones
(special-relativistic aberration, exact in v/c); :func:`correct_solution` re-solves the
attitude of an identified frame against the apparent directions of its matched stars.
Diurnal aberration (the observer's 0.3 arcsec from the Earth's rotation) and light
deflection by the Sun (milliarcseconds away from it) are left out: both need more than a
time (a site, a solar elongation) and are below the centroid errors of a star tracker.
"""

from __future__ import annotations

import dataclasses
import re
import time as clock
import warnings
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from startrack.attitude import solve_wahba
from startrack.input_checks import EPOCH_YEAR, NumberError, check_number
from startrack.io import date_obs_of
from startrack.match_records import Timing
from startrack.sky import Catalog, vectors_to_radec
from startrack.solver._lost_in_space import residuals_arcsec

FITS_SUFFIXES = (".fits", ".fit", ".fts")
C_KM_S = 299792.458


def parse_time(text, where: str = "--time"):
    """An astropy ``Time`` (UTC) from ISO 8601 text such as ``2019-07-29T20:47:26Z``; an
    offset such as ``+02:00`` is honoured, no offset means UTC. A leap second
    (``2016-12-31T23:59:60.5``) and the old FITS date form ``DD/MM/YY`` (1900-1999) are
    read too; the year must lie in startrack.input_checks.EPOCH_YEAR."""
    from astropy.time import Time  # astropy: loaded only when a time is given

    raw = str(text).strip()
    old_fits = _OLD_FITS_DATE.fullmatch(raw)
    if old_fits:  # FITS standard: DD/MM/YY, years 1900-1999
        day, month, year = old_fits.groups()
        raw = f"19{year}-{month}-{day}"
    try:
        moment = datetime.fromisoformat(raw)
    except ValueError:
        moment = _leap_second(raw)
        if moment is None:
            raise NumberError(f"{where}: not an ISO 8601 time (e.g. 2019-07-29T20:47:26Z), "
                             f"got {_shown(text)}") from None
    if isinstance(moment, datetime):
        if moment.tzinfo is not None:
            moment = moment.astimezone(UTC).replace(tzinfo=None)
        check_number(moment.year, f"{where}: year", EPOCH_YEAR)
        moment = Time(moment, scale="utc")
    return moment


_OLD_FITS_DATE = re.compile(r"(\d{2})/(\d{2})/(\d{2})")
_LEAP_SECOND = re.compile(r"(\d{4}-\d{2}-\d{2})[T ](23:59:60(?:\.\d+)?)(Z|[+-]00:?00)?")


def _shown(text) -> str:
    text = repr(text)
    return text if len(text) <= 60 else text[:57] + "..."


def _leap_second(raw: str):
    """A UTC leap second such as ``2016-12-31T23:59:60.5`` (Python's datetime has none),
    as an astropy Time; None if ``raw`` is not one astropy knows."""
    from astropy.time import Time  # astropy: loaded only when a time is given

    match = _LEAP_SECOND.fullmatch(raw)
    if match is None:
        return None
    with warnings.catch_warnings():  # erfa warns of a 60th second that is none
        warnings.simplefilter("ignore")
        try:
            moment = Time(f"{match.group(1)}T{match.group(2)}", format="isot", scale="utc")
        except ValueError:
            return None
        return moment if moment.isot[17:19] == "60" else None


def fits_time(path: str | Path):
    """The DATE-OBS of a FITS image (a ``Time``), or None when it has none or is no FITS.
    (A TIFF's DateTime tag is not used: it is often the time the file was written.)"""
    path = Path(path)
    if path.suffix.lower() not in FITS_SUFFIXES:
        return None
    value = date_obs_of(path)
    return None if value is None else parse_time(value, where=f"{path}: DATE-OBS")


def earth_velocity(time) -> np.ndarray:
    """The Earth's barycentric velocity at ``time`` as a fraction of c (ICRS axes, 3,)."""
    from astropy.coordinates import get_body_barycentric_posvel  # astropy: as above

    _, vel = get_body_barycentric_posvel("earth", time)
    return vel.xyz.to_value("km/s") / C_KM_S


def aberrate(vectors: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Apparent directions (N x 3) of barycentric unit vectors for an observer moving at
    ``beta`` (v/c): ``(u / g + b + (g / (1 + g)) (u.b) b) / (1 + u.b)``, g the Lorentz
    factor. The inverse is the same map with ``-beta``.

    Kept rather than astropy's ICRS to GCRS transform, which adds light deflection (up to
    ~1.5 arcsec near the Sun) but takes several times as long, per frame inside
    identify's timed call (scripts/bench/bench_library_fits.py)."""
    u = np.asarray(vectors, dtype=np.float64)
    b = np.asarray(beta, dtype=np.float64)
    gamma = 1.0 / np.sqrt(1.0 - b @ b)
    ub = u @ b
    out = (u / gamma + b + (gamma / (1.0 + gamma)) * ub[..., None] * b) / (1.0 + ub)[..., None]
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def apparent_catalog(catalog, time):
    """``catalog`` with every star moved to where it appears from the Earth at ``time``
    (what ``simulate --time`` renders)."""
    ra, dec = vectors_to_radec(aberrate(catalog.vectors, earth_velocity(time)))
    return Catalog(catalog.ids, ra, dec, catalog.mag, source=dict(catalog.source))


def correct_solution(solution, obs, catalog_vectors: np.ndarray, time):
    """``solution`` with its attitude re-solved against the apparent directions of its
    matched stars at ``time`` (and residuals recomputed); unsolved ones are unchanged."""
    if not solution.solved or len(solution.obs_index) < 2:
        return solution
    apparent = aberrate(catalog_vectors[solution.cat_index], earth_velocity(time))
    rotation = solve_wahba(obs.vectors[solution.obs_index], apparent)
    return dataclasses.replace(
        solution, rotation=rotation,
        residual_arcsec=residuals_arcsec(rotation, obs, solution.obs_index, apparent))


def correct_result(result, when):
    """A solved :class:`startrack.solver._identifier.FrameResult` with its attitude corrected for
    the aberration at time ``when`` (an astropy Time), the correction's time counted in
    ``identify``; an unsolved one as it is."""
    if not result.solution.solved:
        return result
    t0 = clock.perf_counter()
    solution = correct_solution(result.solution, result.obs, result.catalog.vectors, when)
    ms = (clock.perf_counter() - t0) * 1000.0
    timing = Timing(result.timing.centroid, result.timing.identify + ms,
                    result.timing.total + ms)
    solution = dataclasses.replace(solution, identify_ms=solution.identify_ms + ms)
    return dataclasses.replace(result, solution=solution, timing=timing,
                               time_utc=when.utc.isot)
