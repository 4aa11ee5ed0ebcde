# tactile-cli: set-up, tests, demo and batch targets.
#
#   make demo                 create .venv, install, run the end-to-end demo (writes demo_out/)
#   make test                 create .venv if missing, run the test suite
#   make ingest RAW=dir OUT=dir [INGEST_FLAGS="--width 640 --height 480"]
#                             one HDF5 file per raw recording; parallel under make -j;
#                             outputs that are up to date are skipped
#   make bench                run the benchmarks in benchmarks/

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
TACTILE := $(BIN)/tactile

.PHONY: demo test ingest bench lint clean
.DELETE_ON_ERROR:

# torch is pinned to the CPU build that lies on the project machines' disk (a newer or
# unpinned torch pulls a multi-GB CUDA build); see pyproject's `ml` extra.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[ml,dev]"
	touch $@

test: $(STAMP)
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check tactile_cli tests benchmarks

DEMO ?= demo_out
demo: $(STAMP)
	$(BIN)/python -m tactile_cli.demo --out $(DEMO)

bench: $(STAMP)
	$(BIN)/python benchmarks/ingest.py

# ---- batch ingest: one output per input, atomic writes, up-to-date outputs skipped ----
RAW ?= raw
OUT ?= out
INGEST_FLAGS ?=
RAW_FILES := $(wildcard $(RAW)/*.aedat4 $(RAW)/*.npy $(RAW)/*.csv)
OUT_FILES := $(patsubst $(RAW)/%,$(OUT)/%.h5,$(RAW_FILES))

ingest: $(OUT_FILES)
	@echo "$(words $(OUT_FILES)) file(s) up to date in $(OUT)/"

# --overwrite is safe here: make only reruns a target that is missing or older than its
# input, and tactile writes a temporary file and renames it, so an interrupted run leaves
# no half-written target behind and the next `make` rebuilds exactly what is missing.
$(OUT)/%.h5: $(RAW)/% | $(STAMP)
	@mkdir -p $(@D)
	$(TACTILE) ingest "$<" --out "$@" --overwrite --no-progress $(INGEST_FLAGS)

clean:
	rm -rf $(DEMO) build dist *.egg-info .pytest_cache
