"""Compare two `startrack compare` runs frame by frame, timing aside: the check that a
refactor leaves behaviour unchanged.

    .venv/bin/python scripts/validation/diff_frames.py out/before/frames.csv out/after/frames.csv

Prints the number of rows in each, the rows whose non-timing columns differ (the first
few in full) and exits 1 when any differs.
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

KEY = ["condition", "frame", "method"]


def differing(before: pd.DataFrame, after: pd.DataFrame) -> pd.DataFrame:
    """Rows of ``after`` whose columns shared with ``before`` (timings left out) differ."""
    shared = [c for c in before.columns if c in after.columns
              and not c.endswith("_ms") and "time" not in c]
    merged = before[shared].merge(after[shared], on=KEY, how="outer", suffixes=("_a", "_b"),
                                  indicator=True)
    cols = [c for c in shared if c not in KEY]
    changed = merged["_merge"] != "both"
    for c in cols:
        a, b = merged[f"{c}_a"], merged[f"{c}_b"]
        changed |= ~((a == b) | (a.isna() & b.isna()))
    return merged[changed]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before")
    ap.add_argument("after")
    args = ap.parse_args(argv)
    before, after = pd.read_csv(args.before), pd.read_csv(args.after)
    diff = differing(before, after)
    print(f"rows: {len(before)} before, {len(after)} after; differing: {len(diff)}")
    if len(diff):
        print(diff.head(5).to_string())
    return 1 if len(diff) else 0


if __name__ == "__main__":
    sys.exit(main())
