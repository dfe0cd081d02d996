# One-command set-up: `make demo` runs the main job, `make test` runs the test suite.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench clean astrometry astrometry-ci results

# The compiled core is built by the install: a changed kernel source reinstalls.
$(STAMP): pyproject.toml setup.py $(wildcard startrack/_core/*.pyx startrack/_core/*.pxd startrack/_core/*.pxi)
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/startrack compare

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check .

# Both papers' experiments re-run at the code as it is (docs/results.md, docs/data/), then
# the README's roll-up of their verdicts. Full size unless told, e.g.
# make results RADIAL_SIZE="--frames 250 --raw-frames 120 --label-frames 80"
PAPER2011_SIZE ?=
RADIAL_SIZE ?=
results: $(STAMP)
	$(BIN)/python scripts/paper2011.py --jobs 2 $(PAPER2011_SIZE)
	$(BIN)/python scripts/radial_features.py --jobs 2 $(RADIAL_SIZE)
	$(BIN)/python scripts/readme_results.py --papers-only

# astrometry.net (the `astrometry` peer) and every Tycho-2 index file (the tycho2 sky),
# from Debian's packages: about 190 MB to download, 300 MB installed. Needs root.
ASTROMETRY_PACKAGES := astrometry.net astrometry-data-tycho2-07-littleendian \
	astrometry-data-tycho2-08-littleendian astrometry-data-tycho2-09-littleendian \
	astrometry-data-tycho2-10-19-littleendian
# The smallest set for narrow fields: solve-field and index 4107 (1.87 million stars).
ASTROMETRY_CI_PACKAGES := astrometry.net astrometry-data-tycho2-07-littleendian

astrometry:
	apt-get update && apt-get install -y --no-install-recommends $(ASTROMETRY_PACKAGES)

astrometry-ci:
	apt-get update && apt-get install -y --no-install-recommends $(ASTROMETRY_CI_PACKAGES)

clean:
	rm -rf $(VENV) out .pytest_cache
