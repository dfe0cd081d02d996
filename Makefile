# One-command set-up: `make demo` runs the main job, `make test` runs the test suite.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench clean astrometry astrometry-ci results

# The compiled core is built by the install: a changed kernel source reinstalls.
$(STAMP): pyproject.toml setup.py $(shell find startrack/_core -name '*.pyx' -o -name '*.pxd' -o -name '*.pxi')
	@echo "set-up (once): a virtual environment in $(VENV)/, startrack's dependencies, and its"
	@echo "compiled core (Cython and C, one module per .pyx). Usually a few minutes on an idle"
	@echo "2-core machine, most of it compiling (pip shows 'Building editable ...' meanwhile);"
	@echo "longer on a loaded machine or without a pip cache. Later runs skip it."
	@start=$$(date +%s); \
	echo "[1/3] creating $(VENV)/" && $(PY) -m venv $(VENV) && \
	echo "[2/3] upgrading pip" && $(BIN)/pip install --quiet --upgrade pip && \
	echo "[3/3] installing startrack and its dependencies, compiling the core" && \
	$(BIN)/pip install --progress-bar off -e '.[dev]' && \
	touch $(STAMP) && echo "set-up done in $$(( $$(date +%s) - start )) s"

demo: $(STAMP)
	@echo "demo: startrack compare, the 2011 paper's experiment (angle, triangle and hybrid on"
	@echo "7 conditions x 1000 frames; about a minute on 2 idle cores). A new folder in"
	@echo "out/compare/ each run; out/compare/latest/report.md is the newest report."
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
	$(BIN)/python scripts/papers/paper2011.py --jobs 2 $(PAPER2011_SIZE)
	$(BIN)/python scripts/papers/radial_features.py --jobs 2 $(RADIAL_SIZE)
	$(BIN)/python scripts/docs/readme_results.py --papers-only

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
