"""The compiled labelling (startrack._core.verify.entry_points.label_stars) over the pairs
within the
radius gives what the dense observed x catalog formulation gives, on random frames built
to exercise every rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from labelling_dense_reference import label_kernel as dense_kernel
from startrack._core.verify.entry_points import label_stars

# The order of the labelling's thresholds after the positions in the cases below (the
# fields of the compiled LabelParams structure).
FIELDS = ("has_flux", "radius2", "sigma0", "area", "log_gap", "log_false_odds", "resolve2",
          "mag_sigmas", "min_mag_sigma", "min_sigma_px", "min_fit")


def label_kernel(ox, oy, x, y, mag, rows, flux, *params):
    """The compiled labelling with the dense reference's positional arguments."""
    return label_stars(ox, oy, x, y, mag, rows, flux, dict(zip(FIELDS, params, strict=True)))


def _case(rng: np.random.Generator) -> tuple:
    """A random labelling input: catalog stars, observed stars near some of them (pairs
    and triples within the radius, duplicates), false stars, odd fluxes and magnitudes."""
    m = int(rng.integers(0, 30))
    x, y = rng.uniform(0, 60, m), rng.uniform(0, 60, m)
    if m and rng.random() < 0.3:  # close catalog pairs: unresolved and ambiguous stars
        k = int(rng.integers(1, m + 1))
        x[:k] = x[rng.integers(0, m, k)] + rng.normal(0, 1.5, k)
    mag = rng.uniform(1, 7, m)
    seen = rng.random(m) < rng.uniform(0.3, 1.0)
    n_false = int(rng.integers(0, 8))
    ox = np.concatenate([x[seen] + rng.normal(0, 0.7, seen.sum()), rng.uniform(0, 60, n_false)])
    oy = np.concatenate([y[seen] + rng.normal(0, 0.7, seen.sum()), rng.uniform(0, 60, n_false)])
    flux = 10 ** (-0.4 * (np.concatenate([mag[seen], rng.uniform(1, 7, len(ox) - seen.sum())])
                          + rng.normal(0, 0.2, len(ox)) - 20))
    if len(ox) and rng.random() < 0.3:
        flux[rng.integers(0, len(ox), 2)] = rng.choice([np.nan, 0.0, -1.0, np.inf])
    if len(ox) and rng.random() < 0.1:
        ox[rng.integers(0, len(ox))] = np.nan
    if m and rng.random() < 0.05:
        mag[rng.integers(0, m)] = np.nan
    if rng.random() < 0.2 and len(ox) > 1:  # exact duplicates: ties in distance
        ox[1], oy[1] = ox[0], oy[0]
    radius2 = float(rng.choice([0.0, 1.0, 4.0, 9.0, 25.0, 400.0, np.inf]))
    rows = rng.permutation(1000)[:m].astype(np.int64)
    return (ox, oy, x, y, mag, rows, flux, bool(rng.random() < 0.8), radius2,
            float(rng.choice([0.5, 1.0, np.nan])), float(3600.0 if rng.random() < 0.95 else 0.0),
            math.log(float(rng.choice([1e-3, 0.1, 1.0]))), math.log(1e-3),
            float(rng.choice([0.0, 4.0])), 4.0, float(rng.choice([0.0, 0.03])),
            float(rng.choice([0.0, 0.02])), int(rng.integers(0, 7)))


def _run(kernel, args):
    try:
        return kernel(*args)
    except (ValueError, ZeroDivisionError) as err:
        return type(err)


def _same(a, b) -> bool:
    if isinstance(a, type) or isinstance(b, type):
        return a is b
    return all(np.array_equal(u, v, equal_nan=True) for u, v in zip(a, b, strict=True))


@pytest.mark.parametrize("seed", range(4))
def test_pairs_kernel_equals_the_dense_tables(seed):
    rng = np.random.default_rng(seed)
    outcomes = set()
    for _ in range(500):
        args = _case(rng)
        got, want = _run(label_kernel, args), _run(dense_kernel, args)
        assert _same(got, want), args
        if not isinstance(got, type):
            outcomes.update(np.flatnonzero(got[2]).tolist())
            outcomes.add("reported" if len(got[0]) else "none")
    # The random frames reach every rule, not just the easy path.
    assert outcomes >= {0, 1, 2, 3, "reported", "none"}


def test_empty_and_far_inputs():
    empty = np.zeros(0)
    rows = np.zeros(0, np.int64)
    common = (True, 16.0, 1.0, 1e4, math.log(1e-3), math.log(1e-3), 4.0, 5.0, 0.03, 0.02, 5)
    got = label_kernel(empty, empty, empty, empty, empty, rows, empty, *common)
    assert len(got[0]) == 0 and got[2].sum() == 0
    far = np.array([1e6, 2e6])
    near = np.array([1.0, 5.0])
    args = (near, near, far, far, near, np.arange(2, dtype=np.int64), near, *common)
    assert _same(label_kernel(*args), dense_kernel(*args))
