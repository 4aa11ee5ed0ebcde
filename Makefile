# tactile-cli: set-up, tests, demo and batch targets.
#
#   make demo                 create .venv, install, run the end-to-end demo (writes demo_out/)
#   make test                 create .venv if missing, run the test suite
#   make ingest RAW=dir OUT=dir [INGEST_FLAGS="--width 640 --height 480"]
#                             one HDF5 file per raw recording; parallel under make -j;
#                             outputs that are up to date are skipped
#   make sweep-vibro          paper 001's grid (3 models x 6 windows x 8 channel sets) on Dask
#   make bench                run the benchmarks in benchmarks/ (figures: benchmarks/RESULTS.md)
#   make bench-scale          batch commands at 1 and 2 Dask workers (issue 18; ~15 min)
#   make fuzz                 every command on the seeded corpus of damaged inputs (issue 20):
#                             counts per outcome class (`make test` runs a fast subset)

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
TACTILE := $(BIN)/tactile

.PHONY: sweep-vibro bench-long bench-scale demo demo-lanes demo-lane-events demo-lane-learn demo-lane-figures demo-lane-data demo-chains demo-events-core demo-events-figures demo-vibro demo-taxel demo-visuo demo-events demo-learn demo-real demo-report test test-slow test-all ingest bench lint clean fuzz docs docs-serve docs-figures
.DELETE_ON_ERROR:

# torch is pinned to the CPU build that lies on the project machines' disk (a newer or
# unpinned torch pulls a multi-GB CUDA build); see pyproject's `ml` extra.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[ml,dev]"
	touch $@

# `make test`: the quick tier (under 10 minutes on 2 cores); `make test-slow`: the end-to-end
# tests marked slow (trainings, Dask clusters, the damaged-input subset, docs pages; about 15
# minutes); `make test-all` (and CI): both.
test: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

test-all: $(STAMP)
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check tactile_cli tests benchmarks

# The demo: sample recordings of every format (generated), the real recordings from other
# labs in ../shared/data when present, each ingested into HDF5 with its origin as trial
# labels (origin, dataset, lab: tactile_cli/store/origin.py), validated, summarised; the
# event chain of paper 000 on simulated scenes; models trained on model-based synthetic data
# and tested on a simulated scene they never saw; and one HTML report that tags every
# result with where its data come from.
DEMO   ?= demo_out
SHARED ?= ../shared/data
SAMPLES_LABELS := --label origin=synthetic --label dataset=tactile-samples
demo: $(STAMP)
	rm -rf $(DEMO)
	mkdir -p $(DEMO)/h5
	$(TACTILE) samples $(DEMO)/raw --seed 0
	$(TACTILE) ingest $(DEMO)/raw/events.csv --width 640 --height 480 $(SAMPLES_LABELS) --out $(DEMO)/h5/events_csv.h5
	$(TACTILE) ingest $(DEMO)/raw/events.npy --width 640 --height 480 $(SAMPLES_LABELS) --out $(DEMO)/h5/events_npy.h5
	$(TACTILE) ingest $(DEMO)/raw/accel_tree --format accel-tree $(SAMPLES_LABELS) --out $(DEMO)/h5/accel_tree.h5
	$(TACTILE) ingest $(DEMO)/raw/taxel --mapping $(DEMO)/raw/taxel/taxels.yaml $(SAMPLES_LABELS) --out $(DEMO)/h5/taxel.h5
	$(TACTILE) ingest $(DEMO)/raw/visuotactile/press_01 $(DEMO)/raw/visuotactile/press_02 $(SAMPLES_LABELS) --out $(DEMO)/h5/visuotactile.h5
	$(TACTILE) ingest $(DEMO)/raw/robot/press.bag --mapping configs/rosbag_tactile_rig.yaml --out $(DEMO)/h5/rosbag1.h5
	$(TACTILE) ingest $(DEMO)/raw/robot/press_ros2 --mapping configs/rosbag_tactile_rig.yaml --out $(DEMO)/h5/rosbag2.h5
	$(TACTILE) ingest $(DEMO)/raw/robot/press.mcap --mapping configs/rosbag_tactile_rig.yaml --out $(DEMO)/h5/mcap.h5
	$(TACTILE) ingest $(DEMO)/raw/robot/press.mp4 $(SAMPLES_LABELS) --out $(DEMO)/h5/video.h5
	$(MAKE) --no-print-directory -j2 --output-sync=target demo-lanes DEMO=$(DEMO)
	$(TACTILE) plot $(DEMO)/h5/*.h5 --out $(DEMO)/quicklook --max-trials 2
	$(MAKE) --no-print-directory demo-report DEMO=$(DEMO)

# Two lanes side by side (`make -j2 demo-lanes` in `demo`; every training runs on one thread,
# so its results do not change; each target's output is printed when it finishes), as one
# dependency graph that make schedules on two job slots:
#   learning lane: demo-events-core (the scene, FOS fits, synthetic trials) -> demo-learn;
#   data lane: the real recordings ingested, every ingested file validated and summarised (a
#   fixed list, so the other lane's files never enter it), the real-data step and the other
#   four chains (demo-chains) -> the event chain's figures (demo-events-figures, which also
#   wait for demo-events-core).
DEMO_INGESTED := events_csv events_npy accel_tree taxel visuotactile rosbag1 rosbag2 mcap video dvxplorer xela_slip biotac_slide20
demo-lanes: demo-lane-learn demo-lane-figures
demo-lane-events: $(STAMP)
	$(MAKE) --no-print-directory demo-events-core DEMO=$(DEMO)
demo-lane-learn: demo-lane-events
	$(MAKE) --no-print-directory demo-learn DEMO=$(DEMO)
demo-lane-figures: demo-lane-events demo-lane-data
	$(MAKE) --no-print-directory demo-events-figures DEMO=$(DEMO)
demo-lane-data: $(STAMP)
	@if [ -d "$(SHARED)" ]; then \
	  set -e; echo "real recordings from $(SHARED):"; \
	  $(TACTILE) ingest $(SHARED)/aedat4/dvxplorer_sample.aedat4 --label origin=recorded --label dataset=dvxplorer_sample --label "lab=iniVation DVXplorer sample, from the tonic project test data" --out $(DEMO)/h5/dvxplorer.h5; \
	  $(TACTILE) ingest $(SHARED)/xela_slip --mapping configs/xela_slip.yaml --out $(DEMO)/h5/xela_slip.h5; \
	  $(TACTILE) ingest $(SHARED)/biotac_slide20 --mapping configs/biotac_slide20.yaml --out $(DEMO)/h5/biotac_slide20.h5; \
	else echo "($(SHARED) not found: real recordings skipped)"; fi
	files=""; for n in $(DEMO_INGESTED); do if [ -f $(DEMO)/h5/$$n.h5 ]; then files="$$files $(DEMO)/h5/$$n.h5"; fi; done; \
	$(TACTILE) validate $$files && for f in $$files; do $(TACTILE) info "$$f" || exit 1; done
	$(MAKE) --no-print-directory demo-chains DEMO=$(DEMO)

demo-chains: $(STAMP)
	$(MAKE) --no-print-directory demo-real DEMO=$(DEMO)
	$(MAKE) --no-print-directory demo-accel DEMO=$(DEMO)
	$(MAKE) --no-print-directory demo-vibro DEMO=$(DEMO)
	$(MAKE) --no-print-directory demo-taxel DEMO=$(DEMO)
	$(MAKE) --no-print-directory demo-visuo DEMO=$(DEMO)

# The event-sensor chain of paper 000 on a simulated marker-event scene with known ground
# truth: simulate -> ingest (with the truth as annotations and labels, origin=simulated) ->
# accumulate and segment -> fit-fos (eqs. 16-17, figures like Figs. 11-12) -> synth: the
# training trajectories drawn from those fits (sec. 5.1), with ROI centroid trajectories for
# the spatial LSTM (sec. 5.2) -> frames, slip rates and fuzzy force grades.
SCENE_GROUPS ?= 2
demo-events: $(STAMP)
	$(MAKE) --no-print-directory demo-events-core DEMO=$(DEMO)
	$(MAKE) --no-print-directory demo-events-figures DEMO=$(DEMO)

# What demo-learn needs (the scene, its fits, the synthetic trials), then the figures.
demo-events-core: $(STAMP)
	rm -rf $(DEMO)/scene $(DEMO)/events
	mkdir -p $(DEMO)/events $(DEMO)/h5
	$(TACTILE) simulate marker-events --out $(DEMO)/scene --groups $(SCENE_GROUPS) --seed 0 --no-progress
	$(TACTILE) ingest $(DEMO)/scene/*.npy --width 640 --height 480 --annotations $(DEMO)/scene/annotations.csv --trial-labels $(DEMO)/scene/trials.csv --out $(DEMO)/h5/scene.h5 --overwrite --no-progress
	$(TACTILE) accumulate $(DEMO)/h5/scene.h5 --segment --trial g1_level01 --trial g1_level06 --trial g1_level12 --plot $(DEMO)/events/counts --no-progress
	$(TACTILE) fit-fos $(DEMO)/h5/scene.h5 --plot $(DEMO)/events/fits --csv $(DEMO)/events/fits.csv
	$(TACTILE) synth --fits $(DEMO)/h5/scene.h5 --centroids $(DEMO)/scene/scene.json --n 240 --seed 1 --out $(DEMO)/h5/synth_train.h5 --overwrite

demo-events-figures: $(STAMP)
	$(TACTILE) frames $(DEMO)/h5/scene.h5 --trial g1_level06 --rois $(DEMO)/scene/scene.json --window-ms 100 --median 3 --sheet-only --out $(DEMO)/events/frames
	$(TACTILE) slip-rate $(DEMO)/h5/scene.h5 --rois $(DEMO)/scene/scene.json --plot $(DEMO)/events/slip
	$(TACTILE) grade $(DEMO)/h5/scene.h5 --plot $(DEMO)/events/grade

# The learning chain of paper 000 (Table I, sec. 5.2): four model families trained only on
# the synthetic trials that demo-events drew from the FOS fits of scene (seed 0), and the
# spatial-temporal LSTM on the same trials' ROI centroid trajectories; all tested on a second
# simulated scene (seed 1: scene_test) that was used for nothing else (no fit, no synth, no
# training), so the report's simulated accuracies are on recordings the models never saw.
# Each model is exported to ONNX (demo_out/exported/) and evaluated with the exported file
# checked against it and timed beside PyTorch. Then compared by accuracy and cost (torch and
# exported latency), and perturbed. Needs demo-events first.
# The temporal LSTM trains 20 epochs here instead of its config's 40 (cosine schedule over
# 20): half the demo's longest step (55 -> 27 s on 2 cores); on scene_test it scored 99.6 %
# against 99.5 % at 40 epochs (same validation accuracy, 99.47 %).
DEMO_FAMILIES := lstm cnn1d fnn mlp
DEMO_LSTM_EPOCHS ?= 20
DEMO_RUNS := $(foreach m,$(DEMO_FAMILIES),$(DEMO)/runs/$(m)) $(DEMO)/runs/lstm_spatial
demo-learn: $(STAMP)
	rm -rf $(DEMO)/runs $(DEMO)/scene_test $(DEMO)/exported
	mkdir -p $(DEMO)/exported
	$(TACTILE) simulate marker-events --out $(DEMO)/scene_test --groups $(SCENE_GROUPS) --seed 1 --no-progress
	$(TACTILE) ingest $(DEMO)/scene_test/*.npy --width 640 --height 480 --annotations $(DEMO)/scene_test/annotations.csv --trial-labels $(DEMO)/scene_test/trials.csv --out $(DEMO)/h5/scene_test.h5 --overwrite --no-progress
	$(TACTILE) centroids $(DEMO)/h5/scene_test.h5 --rois $(DEMO)/scene_test/scene.json --out $(DEMO)/h5/scene_test_centroids.h5 --overwrite --no-progress
	for m in $(DEMO_FAMILIES); do \
	  epochs=""; if [ $$m = lstm ]; then epochs="--epochs $(DEMO_LSTM_EPOCHS)"; fi; \
	  $(TACTILE) train configs/train_$${m}_actions.yaml --data $(DEMO)/h5/synth_train.h5 --out $(DEMO)/runs/$$m $$epochs --no-progress || exit 1; \
	  $(TACTILE) export $(DEMO)/runs/$$m --out $(DEMO)/exported/$$m.onnx --overwrite || exit 1; \
	  $(TACTILE) evaluate $(DEMO)/runs/$$m --data $(DEMO)/h5/scene_test.h5 --exported $(DEMO)/exported/$$m.onnx || exit 1; \
	done
	$(TACTILE) train configs/train_lstm_spatial.yaml --data $(DEMO)/h5/synth_train.h5 --out $(DEMO)/runs/lstm_spatial --no-progress
	$(TACTILE) evaluate $(DEMO)/runs/lstm_spatial --data $(DEMO)/h5/scene_test_centroids.h5 --name scene_test
	$(TACTILE) compare $(DEMO_RUNS) --out $(DEMO)/compare
	$(TACTILE) perturb $(foreach m,$(DEMO_FAMILIES),$(DEMO)/runs/$(m)) --data $(DEMO)/h5/scene_test.h5 --out $(DEMO)/perturb

# ---- REAL DATA, CROSS-VALIDATED (issues 11 and 34) -----------------------------------------
# The place for the real-data comparison: BioTac texture over 20 materials (Gao et al., IROS
# 2020), cross-validated by blocks of recordings (samples 1-5 against 6-10 of every material,
# both ways: the split that keeps neighbouring recordings apart; a stratified split, which
# interleaves them, scores several points higher: benchmarks/RESULTS.md, "Real data:
# texture"), per-trial accuracy with intervals. For each config x in DEMO_REAL_CONFIGS:
#   tactile train configs/train_<x>.yaml --data $(DEMO)/h5/biotac_slide20.h5 --cv 2 --out $(DEMO)/runs_real/<x>
#   tactile evaluate $(DEMO)/runs_real/<x>
# cnn2d_..._zscore: spectrogram CNN on the 2.2 kHz vibration, each window z-scored;
# mlp_..._nolevel: the smallest model, summary features of the electrodes without their
# absolute levels. Both configs split `blocked` by `sample`. Skipped when the BioTac
# recordings were not ingested ($(SHARED) absent). demo-report gives every
# $(DEMO)/runs_real/<x> to the report, which lists recorded-data results first.
DEMO_REAL_CONFIGS ?= cnn2d_biotac_texture_zscore mlp_biotac_texture_nolevel
# The smallest of them again at seeds 0-2 (`tactile seed-spread`, one seed after another on
# one core, in the lane that has time to spare): how much of its figure is the seed.
DEMO_SPREAD_CONFIG ?= mlp_biotac_texture_nolevel
demo-real: $(STAMP)
	rm -rf $(DEMO)/runs_real $(DEMO)/spread_real $(DEMO)/.spread_real.seed-spread-partial
	@if [ ! -f $(DEMO)/h5/biotac_slide20.h5 ]; then echo "(no BioTac recordings: real-data step skipped)"; exit 0; fi; \
	for m in $(DEMO_REAL_CONFIGS); do \
	  $(TACTILE) train configs/train_$$m.yaml --data $(DEMO)/h5/biotac_slide20.h5 --cv 2 --out $(DEMO)/runs_real/$$m --no-progress || exit 1; \
	  $(TACTILE) evaluate $(DEMO)/runs_real/$$m || exit 1; \
	done; \
	$(TACTILE) seed-spread configs/train_$(DEMO_SPREAD_CONFIG).yaml --data $(DEMO)/h5/biotac_slide20.h5 --cv 2 --seeds 0-2 --workers 0 --out $(DEMO)/spread_real --no-progress
# ---- end of the real-data step ------------------------------------------------------------

# The accelerometer chain of paper 001, small: two short simulated vibro-slip scenes (seed 0
# to train on, seed 1 to test on, 2 s per recording), prepared into 0.5 s segments with the
# speed target, one multi-task spectrogram CNN (motion, texture, speed) for 3 epochs, and the
# detection delay of sec. 6.5. The full study is in benchmarks/RESULTS.md ("Accelerometer").
demo-accel: $(STAMP)
	rm -rf $(DEMO)/accel $(DEMO)/runs_accel
	mkdir -p $(DEMO)/accel
	for s in 0 1; do \
	  $(TACTILE) simulate vibro-slip --out $(DEMO)/accel/scene$$s --duration 2 --seed $$s --no-progress || exit 1; \
	  $(TACTILE) ingest $(DEMO)/accel/scene$$s --format accel-tree --label origin=simulated --label "dataset=vibro-slip seed $$s" --out $(DEMO)/accel/scene$$s.h5 --no-progress || exit 1; \
	  $(TACTILE) accel-prepare $(DEMO)/accel/scene$$s.h5 --out $(DEMO)/accel/prepared$$s.h5 --segment-s 0.5 --no-progress || exit 1; \
	  rm -rf $(DEMO)/accel/scene$$s; \
	done
	$(TACTILE) train configs/train_cnn2d_vibro.yaml --data $(DEMO)/accel/prepared0.h5 --out $(DEMO)/runs_accel/cnn2d --epochs 3 --no-progress
	$(TACTILE) evaluate $(DEMO)/runs_accel/cnn2d --data $(DEMO)/accel/prepared1.h5 --name vibro_seed1
	$(TACTILE) detect-delay $(DEMO)/runs_accel/cnn2d --data $(DEMO)/accel/prepared1.h5

# The active-vibration chain of paper 003, small (about 30 s): the lumped model's spectra
# without and with contact (like Fig. 3A), a simulated VibroTouch scene (3 gripper-object
# and 1 human-touch trial, seed 0), the vibration and force triggers scored against the
# truth with a figure like Fig. 5 and the band-finder, and the same detector following one
# trial's samples as a live stream with its per-update latency. The full study is in
# benchmarks/RESULTS.md ("VibroTouch").
demo-vibro: $(STAMP)
	rm -rf $(DEMO)/vibro
	mkdir -p $(DEMO)/vibro
	$(TACTILE) vibro-model configs/vibro_model.yaml --plot $(DEMO)/vibro/model_spectra.png
	$(TACTILE) simulate vibrotouch --out $(DEMO)/vibro/scene.h5 --contact-trials 3 --touch-trials 1 --seed 0 --no-progress
	$(TACTILE) validate $(DEMO)/vibro/scene.h5
	$(TACTILE) detect-contact $(DEMO)/vibro/scene.h5 --plot $(DEMO)/vibro/detections.png --find-band
	$(TACTILE) detect-contact $(DEMO)/vibro/scene.h5 --trial contact_00 --samples-out $(DEMO)/vibro/contact_00.txt
	$(TACTILE) detect-contact - --follow < $(DEMO)/vibro/contact_00.txt

# The taxel-array chain of paper 004, small (well under a minute): a simulated PVDF scene
# (12 object/hand and 12 object/world trials, seed 0), the slip interface classified with
# both features (Gamma, single- and multi-finger G2) by 10-fold CV with the nested band
# search and a figure like Fig. 12, and the features as a stream for `tactile train`. With
# 24 trials one trial is 4.2 points of accuracy, so the demo's nested figures scatter; the
# full study (60 trials per preset and seed, three held-out seeds) is in
# benchmarks/RESULTS.md ("Taxel arrays").
demo-taxel: $(STAMP)
	rm -rf $(DEMO)/taxel
	mkdir -p $(DEMO)/taxel
	$(TACTILE) simulate taxel-slip --out $(DEMO)/taxel/scene.h5 --preset pvdf --trials 12 --seed 0 --no-progress
	$(TACTILE) validate $(DEMO)/taxel/scene.h5
	$(TACTILE) slip-interface $(DEMO)/taxel/scene.h5 --plot $(DEMO)/taxel/features.png --out $(DEMO)/taxel/slip_interface.json --no-progress
	$(TACTILE) features spectral $(DEMO)/taxel/scene.h5 --out $(DEMO)/taxel/features.h5 --no-progress

# The visuotactile chain of paper 002 on a DIGIT-like scene with known height maps: ball
# presses -> contact circles and sphere normals (eqs. 5-8) -> the 5-32-32-32-3 normal MLP ->
# height maps (eq. 9 + DST Poisson, RMSE against the truth) -> the slip signal (eq. 10) from
# heights and from colour change, scored against the slip labels -> the slip-avoidance
# monitor replayed on a closed-loop scene (Fig. 14). Calibration and trials come from one
# simulated sensor (seed 0), as a lab calibrates the sensor it records with.
VISUO := $(DEMO)/visuo
demo-visuo: $(STAMP)
	rm -rf $(VISUO)
	mkdir -p $(VISUO)/figures
	$(TACTILE) simulate digit-press $(VISUO)/scene --seed 0 --calibration-presses 12 --trials 2 --objects cable,box,hex_key_small --no-progress
	$(TACTILE) ingest $(VISUO)/scene/calibration --trial-labels $(VISUO)/scene/calibration_labels.csv --px-per-mm 16 --out $(VISUO)/calib.h5
	$(TACTILE) ingest $(VISUO)/scene/trials --trial-labels $(VISUO)/scene/trial_labels.csv --px-per-mm 16 --out $(VISUO)/trials.h5
	$(TACTILE) normal-labels $(VISUO)/calib.h5 --out $(VISUO)/pixels.h5 --plot $(VISUO)/figures/calibration
	$(TACTILE) train configs/train_mlp_normals.yaml --data $(VISUO)/pixels.h5 --out $(VISUO)/runs/normals
	$(TACTILE) heightmap $(VISUO)/trials.h5 --model $(VISUO)/runs/normals --truth $(VISUO)/scene/truth --plot $(VISUO)/figures/heightmaps --out $(VISUO)/heights.h5 --no-progress
	$(TACTILE) slip-signal $(VISUO)/heights.h5 --plot $(VISUO)/figures/slip_height --no-progress
	$(TACTILE) slip-signal $(VISUO)/trials.h5 --source intensity --plot $(VISUO)/figures/slip_intensity --no-progress
	$(TACTILE) simulate digit-avoidance $(VISUO)/avoid --seed 0 --object cable --no-progress
	$(TACTILE) monitor $(VISUO)/avoid --plot $(VISUO)/figures/monitor --no-progress

# The report: the real-data runs (when there are any) and the simulated ones, every data
# file, and the figure folders (quick looks of every file, the event chain's figures).
demo-report: $(STAMP)
	$(TACTILE) report $(wildcard $(DEMO)/runs_real/*) $(wildcard $(DEMO)/spread_real) $(DEMO_RUNS) $(wildcard $(DEMO)/runs_accel/*) --data $(DEMO)/h5/*.h5 --figures $(DEMO)/quicklook --figures $(DEMO)/events --figures $(DEMO)/vibro --figures $(DEMO)/taxel --figures $(DEMO)/visuo/figures --title "tactile demo: where every number comes from" --out $(DEMO)/report
	@echo "report: $(abspath $(DEMO))/report/index.html"

bench: $(STAMP)
	$(BIN)/python benchmarks/ingest.py
	$(BIN)/python benchmarks/fit_fos.py
	$(BIN)/python benchmarks/fuzzy.py
	$(BIN)/python benchmarks/export.py

# Damaged and hostile inputs (issue 20): truncated, byte-flipped, retyped and absurd inputs of
# every kind, each run through the commands that take it; prints the counts per outcome
# class and per command as markdown (benchmarks/RESULTS.md). FUZZ_FLAGS="--n-random 4" grows
# the corpus; "--findings FILE" lists every failing run.
FUZZ_FLAGS ?= --seed 0 --n-random 1
fuzz: $(STAMP)
	$(BIN)/python benchmarks/fuzz_corpus.py $(FUZZ_FLAGS) --markdown

# Stability sweeps and accuracy studies: minutes each (about 35 in all on 2 cores); they
# rewrite benchmarks/figures/. xela_loto needs the real recordings in ../shared/data.
bench-long: $(STAMP)
	$(BIN)/python benchmarks/fos_stability.py
	$(BIN)/python benchmarks/grade_stability.py
	$(BIN)/python benchmarks/xela_loto.py
	$(BIN)/python benchmarks/spatial_classifier.py

# Scale-out on Dask (issue 18): 64 ingests and a 16-run sweep at 0 (serial), 1 and 2 local
# workers, outputs checked equal to the serial run; about 15 min on 2 idle cores (run it on
# an otherwise quiet machine: other load skews the ratios). Writes benchmarks/figures/scale*.json.
bench-scale: $(STAMP)
	$(BIN)/python benchmarks/scale.py --job all

# Paper 001's full grid (issue 14, items 4 and 9): 3 models x 6 windows x 8 channel sets
# (configs/sweep_vibro.yaml; 128 runs, 16 n/a) on Dask, each trained on a simulated scene
# (seed 0) and evaluated on another (seed 1), into one table, Fig. 8 and the speed-accuracy
# chart in $(SWEEP_OUT). Estimate on 2 shared cores with 2 workers: about an hour (8 L3R3
# runs of 2 epochs on 2 s recordings took 140 s; the grid trains 128 runs of 5 epochs, the
# one-axis sets faster). A stopped sweep restarted skips its finished runs;
# SWEEP_FLAGS="--scheduler tcp://host:8786" sends the runs to an existing Dask cluster.
SWEEP_OUT ?= out/sweep_vibro
SWEEP_DATA := $(SWEEP_OUT)/data
SWEEP_FLAGS ?=
sweep-vibro: $(STAMP)
	mkdir -p $(SWEEP_DATA)
	for s in 0 1; do \
	  test -f $(SWEEP_DATA)/prepared$$s.h5 && continue; \
	  $(TACTILE) simulate vibro-slip --out $(SWEEP_DATA)/scene$$s --duration 2 --seed $$s --overwrite --no-progress || exit 1; \
	  $(TACTILE) ingest $(SWEEP_DATA)/scene$$s --format accel-tree --label origin=simulated --label "dataset=vibro-slip seed $$s" --out $(SWEEP_DATA)/scene$$s.h5 --overwrite --no-progress || exit 1; \
	  $(TACTILE) accel-prepare $(SWEEP_DATA)/scene$$s.h5 --out $(SWEEP_DATA)/prepared$$s.h5 --segment-s 0.5 --no-progress || exit 1; \
	  rm -rf $(SWEEP_DATA)/scene$$s $(SWEEP_DATA)/scene$$s.h5; \
	done
	$(TACTILE) sweep configs/sweep_vibro.yaml --data $(SWEEP_DATA)/prepared0.h5 --eval-data $(SWEEP_DATA)/prepared1.h5 --out $(SWEEP_OUT)/result $(SWEEP_FLAGS)

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

# ---- documentation site (issue 32): docs/ and mkdocs.yml, built into site/ ---------------
#   make docs           install the `docs` extra into .venv, build site/ with --strict (a
#                       broken link, a missing page or a bad API reference fails the build)
#   make docs-serve     the same site on http://127.0.0.1:8000 while you edit
#   make docs-figures   rerun the tutorials' commands on small generated data and refresh the
#                       PNGs in docs/figures/ (committed; docs/make_figures.py, a few minutes)
# The site needs no network to build or to view: no web fonts, no scripts from a CDN.
DOCS_STAMP := $(VENV)/.docs-stamp
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[ml,dev,docs]"
	touch $@

docs: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site
	@if grep -rlE '<(script|link)[^>]+(src|href)="(https?:)?//' site --include='*.html'; then \
	  echo "docs: the pages above load a script or stylesheet from the network"; exit 1; fi

docs-serve: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs serve --strict

docs-figures: $(STAMP)
	$(BIN)/python docs/make_figures.py
