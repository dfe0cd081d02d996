"""How steady compare's timings are: for every condition and method of a compare run's
summary.csv, its time p95 and mean as multiples of its median (a bench that timed a
compiler, a cache fill or an import would show a p95 or a mean far above the median).

    .venv/bin/startrack compare --out /tmp/c
    .venv/bin/python scripts/validation/compare_time_spread.py /tmp/c
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="a compare --out folder (its summary.csv)")
    args = ap.parse_args()
    s = pd.read_csv(args.out / "summary.csv")
    s = s[s["time_median_ms"] > 0]
    s = s.assign(p95_over_median=s["time_p95_ms"] / s["time_median_ms"],
                 mean_over_median=s["time_mean_ms"] / s["time_median_ms"])
    cols = ["condition", "method", "time_median_ms", "time_p95_ms", "time_mean_ms",
            "p95_over_median", "mean_over_median"]
    print(s[cols].to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    worst_p95 = s.loc[s["p95_over_median"].idxmax()]
    worst_mean = s.loc[s["mean_over_median"].idxmax()]
    print(f"\n{len(s)} condition x method rows; largest p95/median "
          f"{worst_p95['p95_over_median']:.2f} ({worst_p95['method']}, condition "
          f"{worst_p95['condition']}); largest mean/median {worst_mean['mean_over_median']:.2f} "
          f"({worst_mean['method']}, condition {worst_mean['condition']})")


if __name__ == "__main__":
    main()
