"""A seeded random sky: stars uniform on the sphere with a realistic magnitude law."""

from __future__ import annotations

import numpy as np

from startrack.sky._catalog import Catalog, vectors_to_radec

# The real sky has about 3x more stars per magnitude step (log10(3) ~ 0.48 dex/mag).
DEFAULT_GROWTH_PER_MAG = 3.0


def random_sky(
    n_stars: int = 2000,
    seed: int = 0,
    mag_min: float = 0.0,
    mag_max: float = 6.5,
    growth_per_mag: float = DEFAULT_GROWTH_PER_MAG,
) -> Catalog:
    """``n_stars`` stars uniform on the sphere, ids 0..N-1 in generation order.

    Magnitudes follow N(<m) proportional to ``growth_per_mag ** m`` within
    ``[mag_min, mag_max]`` (inverse-CDF sampling), so the count of stars brighter than m
    grows like the real sky's. The same arguments always rebuild the same sky.
    """
    if n_stars < 1:
        raise ValueError("n_stars must be positive")
    if not mag_max > mag_min:
        raise ValueError("mag_max must exceed mag_min")
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n_stars, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    ra, dec = vectors_to_radec(v)
    # CDF(m) = (g^m - g^m0) / (g^m1 - g^m0)  =>  m = log_g(g^m0 + u (g^m1 - g^m0))
    g = float(growth_per_mag)
    u = rng.random(n_stars)
    lo, hi = g**mag_min, g**mag_max
    mag = np.log(lo + u * (hi - lo)) / np.log(g)
    source = {
        "sky": "random",
        "n_stars": int(n_stars),
        "seed": int(seed),
        "mag_min": float(mag_min),
        "mag_max": float(mag_max),
        "growth_per_mag": g,
    }
    return Catalog(ids=np.arange(n_stars, dtype=np.int64), ra_deg=ra, dec_deg=dec, mag=mag,
                   source=source)

__all__ = ["DEFAULT_GROWTH_PER_MAG", "random_sky"]
