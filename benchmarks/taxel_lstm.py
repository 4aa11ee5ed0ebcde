"""Is the small model enough? Paper 004's naive Bayes on Gamma / G2 against an LSTM on the
raw taxel windows, same trials, same folds (issue 15, item 5).

One held-out scene (default seed 11, PVDF preset, 30 object/hand + 30 object/world
trials), then in one run:

- ``tactile slip-interface``'s classifier (:func:`tactile_cli.taxel.slip_interface`):
  Gaussian naive Bayes, 10-fold CV per trial, nested best band; per-trial accuracy;
  training time = the whole nested CV (band search included) / 10 folds; latency = the
  features of one trial (2 s of 2 x 8 channels) plus one prediction;
- ``tactile train configs/train_lstm_taxel_raw.yaml --cv 10`` and ``tactile evaluate``:
  an LSTM on 41 ms raw windows of finger 0 (the trial's label on every window); per-window
  accuracy, per-trial accuracy (majority vote), training time per fold, batch-1 latency
  per window.

The folds are the same: both deal the trials by ``tactile_cli.learn.splits``'s stratified
rule (checked against the run's ``cv_plan.json``).

    .venv/bin/python benchmarks/taxel_lstm.py [--seed 11] [--json]

Writes benchmarks/figures/taxel_lstm.json.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TACTILE = str(Path(sys.executable).with_name("tactile"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    from tactile_cli.store.trials import TactileFile
    from tactile_cli.taxel import (
        FeatureConfig,
        TaxelSceneConfig,
        simulate_taxel_slip,
        slip_interface,
    )
    from tactile_cli.taxel.pipeline import (
        PresetTrials,
        gnb_predict,
        preset_features,
        read_preset_trials,
        stratified_folds,
    )

    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / f"s{args.seed}.h5"
        simulate_taxel_slip(TaxelSceneConfig(presets=("pvdf",)), scene, seed=args.seed)
        fcfg = FeatureConfig()
        t0 = time.perf_counter()
        nb = slip_interface(scene, fcfg)
        nb_cv_s = time.perf_counter() - t0
        with TactileFile(scene) as tf:
            pt = read_preset_trials(tf, "pvdf")
        one = PresetTrials(pt.preset, pt.names[:1], pt.slip_type[:1],
                           [r[:1] for r in pt.rest], [s[:1] for s in pt.slip], pt.rate_hz,
                           pt.delays_s, None, None)
        feats = preset_features(pt, fcfg)
        x = feats.features["g2_multi"].full[:, None]
        y = (pt.slip_type == "world").astype(np.int64)
        reps = 20
        t0 = time.perf_counter()
        for _ in range(reps):
            f1 = preset_features(one, fcfg).features["g2_multi"].full[:, None]
            gnb_predict(x, y, f1)
        nb_latency_ms = 1e3 * (time.perf_counter() - t0) / reps

        run = Path(tmp) / "lstm"
        subprocess.run([TACTILE, "train", str(ROOT / "configs/train_lstm_taxel_raw.yaml"),
                        "--data", str(scene), "--cv", "10", "--out", str(run),
                        "--no-progress"], check=True, capture_output=True)
        subprocess.run([TACTILE, "evaluate", str(run)], check=True, capture_output=True)
        metrics = json.loads(next((run / "eval").glob("*/metrics.json")).read_text())
        run_json = json.loads((run / "run.json").read_text())
        plan = json.loads((run / "cv_plan.json").read_text())
        keys = [f"{scene.name}/{n}" for n in pt.names]
        ours = stratified_folds(keys, pt.slip_type, fcfg.folds, fcfg.seed)
        same = all(sorted(f["test"]) == sorted(k for k, g in zip(keys, ours, strict=True)
                                              if g == f["fold"]) for f in plan["folds"])
    head = metrics["heads"]["slip"]
    folds = run_json["training"]["folds"]
    result = {
        "seed": args.seed, "preset": "pvdf", "n_trials": len(pt.names), "same_folds": same,
        "naive_bayes": [{"feature": s.feature, "per_trial_accuracy_nested": s.nested_best_band,
                         "per_trial_accuracy_full_spectrum": s.full_spectrum}
                        for s in nb.scores],
        "naive_bayes_train_s_per_fold": round(nb_cv_s / fcfg.folds, 4),
        "naive_bayes_latency_ms_per_trial": round(nb_latency_ms, 3),
        "naive_bayes_parameters": 6,  # 2 classes x (mean, variance, prior)
        "lstm_window_accuracy": round(head["accuracy"], 4),
        "lstm_per_trial_accuracy": head["per_trial"]["majority_accuracy"],
        "lstm_train_s_per_fold": round(float(np.mean([f["train_time_s"] for f in folds])), 3),
        "lstm_latency_ms_per_window": metrics["latency"]["batch1_ms_median"],
        "lstm_parameters": metrics.get("model", {}).get("n_params"),
        "lstm_window_ms": 128 / 3.125,
    }
    (ROOT / "benchmarks/figures").mkdir(exist_ok=True)
    (ROOT / "benchmarks/figures/taxel_lstm.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2) if args.json else
          "\n".join(f"{k:36s} {v}" for k, v in result.items()))


if __name__ == "__main__":
    main()
