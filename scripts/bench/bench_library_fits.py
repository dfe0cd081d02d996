"""Where startrack keeps its own code beside a maintained library, the figures that say
why: the TAN-SIP fit against astropy's ``fit_wcs_from_points`` (time and residuals on
the real test frame), the Wilson interval against scipy's ``binomtest`` (time per
summary), the Hipparcos parser against ``pandas.read_fwf`` (time, same numbers), proper
motion against ``SkyCoord.apply_space_motion`` and annual aberration against astropy's
ICRS to GCRS transform (time, differences).

    .venv/bin/python scripts/bench/bench_library_fits.py

Prints the figures; asserts nothing (tests/bench/test_plots.py and tests/sky/test_sky.py hold the
values equal).
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _best(fn, repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls, seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def sip_fit() -> None:
    from astropy.coordinates import SkyCoord
    from astropy.wcs import WCS, FITSFixedWarning
    from astropy.wcs.utils import fit_wcs_from_points

    import startrack
    from startrack.outputs import sip_order_for, solved_wcs_header
    from startrack.sky import vectors_to_radec

    s = startrack.solve(ROOT / "tests/data/realsky_azi45.png", fov_deg=11.42,
                        sky="hipparcos", epoch=2019.6)
    frame = s.frame
    k, rows = frame.solution.obs_index, frame.solution.cat_index
    x, y = frame.obs.x[k], frame.obs.y[k]
    cat = SkyCoord(*vectors_to_radec(frame.catalog.vectors[rows]), unit="deg")
    centre = SkyCoord(s.ra_deg, s.dec_deg, unit="deg")
    order = sip_order_for(len(k))

    def residuals(w) -> np.ndarray:
        ra, dec = w.all_pix2world(x, y, 0)
        return SkyCoord(ra, dec, unit="deg").separation(cat).arcsec

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FITSFixedWarning)
        ours = WCS(solved_wcs_header(frame))
        t_ours = _best(lambda: solved_wcs_header(frame))
        theirs = fit_wcs_from_points((x, y), cat, proj_point=centre, projection="TAN",
                                     sip_degree=order)
        t_theirs = _best(lambda: fit_wcs_from_points((x, y), cat, proj_point=centre,
                                                     projection="TAN", sip_degree=order))
    for name, w, t in (("startrack fit_sip", ours, t_ours),
                       ("astropy fit_wcs_from_points", theirs, t_theirs)):
        r = residuals(w)
        print(f"TAN-SIP order {order}, {len(k)} stars, {name}: {t * 1e3:.1f} ms, "
              f"rms {np.sqrt(np.mean(r ** 2)):.2f} arcsec, max {r.max():.2f} arcsec")


def wilson_interval() -> None:
    from scipy.stats import binomtest

    from startrack.bench import wilson

    rng = np.random.default_rng(0)
    n = np.full(200, 1000)
    k = rng.integers(900, 1001, 200)
    t_ours = _best(lambda: wilson(k, n))
    t_scipy = _best(lambda: [binomtest(int(a), int(b)).proportion_ci(method="wilson")
                             for a, b in zip(k, n, strict=True)])
    print(f"Wilson 95% interval, 200 rates: startrack {t_ours * 1e3:.2f} ms, "
          f"scipy binomtest {t_scipy * 1e3:.1f} ms")


def hipparcos_parser() -> None:
    import pandas as pd

    from startrack.sky import HIP2_COLUMNS, catalog_file, parse_hip2

    path = catalog_file()
    parse_hip2(path)  # compile (cached) before timing
    t_ours = _best(lambda: parse_hip2(path))
    spans = [(a - 1, b) for a, b in HIP2_COLUMNS.values()]

    def read_fwf():
        return pd.read_fwf(path, colspecs=spans, names=list(HIP2_COLUMNS), header=None)

    t_pandas = _best(read_fwf)
    table = read_fwf()
    ours = parse_hip2(path)
    good = table.dropna(subset=["hip", "ra_rad", "dec_rad", "hp"])
    same = np.array_equal(good["hp"].to_numpy(), ours["mag"])
    print(f"Hipparcos hip2.dat, {len(ours['ids'])} stars: startrack {t_ours * 1e3:.0f} ms, "
          f"pandas.read_fwf {t_pandas * 1e3:.0f} ms; same magnitudes: {same}")


def proper_motion() -> None:
    import astropy.units as u
    from astropy.coordinates import SkyCoord
    from astropy.time import Time

    from startrack.sky import CATALOG_EPOCH, hipparcos_arrays, propagate

    a = hipparcos_arrays()
    years = 2019.6 - CATALOG_EPOCH
    t_ours = _best(lambda: propagate(a["ra_deg"], a["dec_deg"], a["pm_ra"], a["pm_dec"],
                                     years))
    ra, dec = propagate(a["ra_deg"], a["dec_deg"], a["pm_ra"], a["pm_dec"], years)

    def astropy_motion():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # no distances: astropy says so
            sky = SkyCoord(ra=a["ra_deg"] * u.deg, dec=a["dec_deg"] * u.deg,
                           pm_ra_cosdec=a["pm_ra"] * u.mas / u.yr,
                           pm_dec=a["pm_dec"] * u.mas / u.yr,
                           obstime=Time(CATALOG_EPOCH, format="jyear"))
            return sky.apply_space_motion(new_obstime=Time(2019.6, format="jyear"))

    t_astropy = _best(astropy_motion)
    moved = astropy_motion()
    sep = SkyCoord(ra * u.deg, dec * u.deg).separation(SkyCoord(moved.ra, moved.dec))
    print(f"proper motion of {len(ra)} Hipparcos stars to 2019.6: startrack "
          f"{t_ours * 1e3:.0f} ms, astropy apply_space_motion {t_astropy * 1e3:.0f} ms; "
          f"largest difference {sep.arcsec.max():.5f} arcsec")


def aberration() -> None:
    from astropy.coordinates import GCRS, CartesianRepresentation, SkyCoord

    from startrack.solver import aberrate, earth_velocity, parse_time

    when = parse_time("2019-07-29T20:47:26Z")
    for n in (60, 100_000):  # one frame's matched stars; a whole catalog (simulate)
        v = np.random.default_rng(0).normal(size=(n, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        ours = aberrate(v, earth_velocity(when))

        def gcrs(v=v):
            c = SkyCoord(CartesianRepresentation(v.T), frame="icrs")
            return c.transform_to(GCRS(obstime=when)).cartesian.xyz.value.T

        g = gcrs()
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        diff = np.degrees(np.arccos(np.clip(np.sum(ours * g, axis=1), -1, 1))) * 3600
        t_ours = _best(lambda v=v: aberrate(v, earth_velocity(when)))
        t_astropy = _best(gcrs)
        print(f"annual aberration, {n} stars: startrack {t_ours * 1e3:.1f} ms, astropy "
              f"ICRS->GCRS {t_astropy * 1e3:.1f} ms; difference median "
              f"{np.median(diff):.4f}, max {diff.max():.3f} arcsec (light deflection)")


if __name__ == "__main__":
    wilson_interval()
    hipparcos_parser()
    proper_motion()
    aberration()
    sip_fit()
