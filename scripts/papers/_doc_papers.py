"""The fixed prose of docs/results.md: what the two papers say (their numbers, not ours)."""

TITLE = """\
# Results: the two papers' comparisons, re-run on the startrack bench

Every claim of the two papers below is quoted and judged by the rules of the next
section, the same for both papers; the README's roll-up is made from the same verdicts.
"""

HEADER = """\
## How this page is made

This page is written by `scripts/papers/_results_doc.py` from the small tables each paper's
script saves in the repository under `docs/data/<section>/`, each with a `run.json` that
records the command, commit, date and machine it was made with; every section below
states them. Nothing here is typed by hand except prose that states no number. The page
is always rebuilt from every section's saved tables, so re-running one paper's script
leaves the other's section as it was. To regenerate it:

```
make results                                        # both papers, then the README's roll-up
make results RADIAL_SIZE="--frames 250 --raw-frames 120 --label-frames 80"  # a smaller run
.venv/bin/python scripts/papers/_results_doc.py            # re-render from the saved tables alone
.venv/bin/python scripts/papers/_results_doc.py --check    # exit 1: a section unsaved or stale
```

`make results` runs `scripts/papers/paper2011.py --jobs 2` and `scripts/papers/radial_features.py
--jobs 2` at their full default sizes unless told a size, then
`scripts/docs/readme_results.py --papers-only`. Each section below gives the exact command,
and so the frame counts, of the run shown, and the commit it ran at: a commit after it
that changes `startrack/` makes the section stale for `--check`.

The frames are the bench's deterministic frames (`startrack.bench._frames`): frame *i* is
the same sky patch in every condition and every method sees the same frames. Each
script makes these measurements on them:

* **verified** (`run_comparison`): the answer `identify()` returns after the shared
  verification. *correct* = every reported identity right and the boresight within
  max(60", 5 sigma); *wrong* = accepted but not correct.
* **verified, five stars** (`top5`, the 2011 section's third grid): the same, when
  `identify()` sees only the five brightest spots: the papers' budget, with no other
  star to confirm with.
* **raw** (`startrack/bench/_raw.py`): the first hypothesis each matcher yields,
  unverified, scored against the truth, and how many wrong hypotheses come before the
  first right one. The papers had no separate verification stage, so their "accuracy"
  is this one.
* **time**: a pass in one process that keeps the fastest of a few runs per frame,
  split into the time inside the matcher's hypothesis generator and the rest
  (verification and attitude); each section states its warm-up, repeats, median and
  p95, and the machine and its load. Methods are compared within one pass.
* **paired tests**: every method sees the same frames, so two methods are compared frame
  by frame with the exact McNemar test (`startrack/bench/_stats.py`); every rate carries
  its 95% Wilson interval.
"""

CLAIMS = """\
## What the papers claim

### Sedaghat, Toloei, Ghanbarpoor (2011): triangle base and search speed

"Automatic star identification using triangle base and increase search speed" (Persian,
English abstract).


The copy we have ends at Figure 9 (the flowchart of the triangle method). **It contains
no results section: no table or figure of time, accuracy, noise levels or false-star
results, and no number to quote.** What it does say:

* Setup (introduction, reassembled from the stored text's scrambled lines and
  translated by us): "We take a sky with a random distribution of 2000
  stars, assume the camera's field of view (0.025 x 0.025), select the five larger
  [brighter] stars and evaluate them. These stars are identified by the angle method,
  the triangle method and the new hybrid method, and compared with one another in time
  required, accuracy and the effect of noise." The unit of 0.025 is not given; its
  section below says what it most likely means (0.025 rad over a 2000-star patch) and
  why our wider field stands for that reading.
* Every claim the paper makes about the three methods is quoted in full in its section
  below, each with its verdict and paired tests: the English abstract as printed; the
  Persian sentences reassembled from the stored text, whose right-to-left lines come out
  in scrambled order (the word order is ours, every word as the text has it), each with
  our translation.

### Radial features + triangles (2017 or after)

"An improved triangle star identification algorithm with radial features" (Chinese, Rocket
Force University of Engineering, Xi'an; it builds on the radial features of Zhang, Wei and
Jiang 2008).


* Camera (section 2, our translation): "a star sensor with a 4 deg x 4 deg field of view,
  CCD resolution 4096 x 4096, pixel size 9 um", several star images "shot on the ground".
  The catalog is "the navigation stars of the field-of-view region": the identification
  is within a known sky patch (RA 107-111 deg, Dec 33-36 deg in the tables), not lost in
  space. No magnitude limit, noise level, false stars or timing are given.
* Initial match threshold: l >= 3/4 Nq (equation 4).
* Table 2 (partial initial identification, 10 observed stars): 7 stars get one
  catalog candidate, 3 get two (e.g. star 3 at (983.55, 1646.07) px: (109.7039, 34.8039)
  or (110.1570, 35.1245) deg).
* Table 3: the improved method identifies 13 observed stars, one catalog star each.
* Table 4 (plain triangle method, "partial misidentified data"): two cases where two
  observed stars are given the same catalog star: (1389.63, 3262.98) and (2178.05,
  3464.10) px both as (108.4258, 33.2400) deg; (1575.91, 1644.82) and (3284.58, 2239.62)
  px both as (109.7102, 34.1462) deg.
* Figure 6 ("number of misidentified stars", plain triangle vs improved, over several
  images) is an image; its values are not in the text. The claim (our translation): "compared
  with the triangle algorithm, the improved triangle algorithm based on radial features
  reduces the misidentification of star points and improves the correctness", and
  (section 1.2) it needs m1 m2 m3 candidate triangles instead of C(m, 3), which "reduces
  the amount of computation". No time is measured.
"""

LIMITS = """\
## Limits of these comparisons

* The 2011 paper's numbers could not be compared because its results are not in the stored
  text; we test its stated claims only, at field widths of our choosing.
* The radial-features paper worked on real ground images of one sky patch with the
  navigation stars of that patch; we use simulated centroids (Gaussian noise, uniform
  false stars), lost in space over the whole sky (harder than the paper's search for
  every method) and within a known patch around the true boresight (the `_patch`
  methods, the paper's setting). Its printed star positions are not Hipparcos
  positions in any frame we tried, so its own images cannot be re-identified here.
* Timings come from a shared machine; read them as ratios within one pass.
"""
