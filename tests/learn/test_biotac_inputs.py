"""benchmarks/biotac_inputs.py: late fusion and the recommendation rule, on hand-made folds."""

from __future__ import annotations

import numpy as np

from tests.conftest import load_benchmark


def _module():
    return load_benchmark("biotac_inputs")


def _fold(trials, t_s, y, p):
    return {"fold": 0, "test": sorted(set(trials)), "trial": np.array(trials),
            "t_s": np.array(t_s, float), "y": np.array(y), "p": np.array(p, float),
            "classes": ["a", "b"]}


def test_fusion_pairs_the_nearest_electrode_window_and_averages_trial_means():
    mod = _module()
    # trial "t1" (class 0): vibration windows end at 0.1, 0.3 s; electrode windows at
    # 0.0, 0.25, 1.0 s
    vib = _fold(["t1", "t1", "t2"], [0.1, 0.3, 0.5], [0, 0, 1],
                [[0.6, 0.4], [0.2, 0.8], [0.5, 0.5]])
    ele = _fold(["t1", "t1", "t1", "t2"], [1.0, 0.0, 0.25, 0.5], [0, 0, 0, 1],
                [[0.0, 1.0], [1.0, 0.0], [0.4, 0.6], [0.1, 0.9]])
    folds, trial_p = mod.fuse([vib], [ele])
    # 0.1 s pairs with 0.0 s (nearest), 0.3 s with 0.25 s, t2's only window with t2's
    np.testing.assert_allclose(folds[0]["p"], [[0.8, 0.2], [0.3, 0.7], [0.3, 0.7]])
    np.testing.assert_allclose(trial_p[0]["t1"],
                               0.5 * (np.array([0.4, 0.6]) + np.array([1.4, 1.6]) / 3))
    s = mod.score(folds, trial_p)
    assert s["n_trials"] == 2 and abs(s["window_accuracy"] - 2 / 3) < 1e-12
    # per trial: t1 fused mean (0.433, 0.567) -> b (wrong), t2 -> b (right)
    assert s["trial_accuracy"] == 0.5


def test_recommendation_prefers_the_smallest_model_indistinguishable_from_the_reference():
    mod = _module()

    def row(label, acc, lo, sd, n_params):
        return {"label": label, "trial_accuracy": acc, "trial_accuracy_ci95": [lo, 1.0],
                "trial_accuracy_fold_std": sd, "n_params": n_params, "batch1_ms_median": 0.1}

    rows = [row("big", 0.97, 0.94, 0.02, 100_000),    # top point estimate and lower bound
            row("small", 0.95, 0.91, 0.03, 1_000),    # inside the reference's interval
            row("shaky", 0.96, 0.90, 0.12, 500),      # fold spread too wide
            row("weak", 0.90, 0.85, 0.02, 100)]       # below the reference's lower bound
    rec = mod.recommend(rows)
    assert rec["reference"] == "big" and rec["top_point_estimate"] == "big"
    assert rec["eligible"] == ["big", "small"] and rec["recommended"] == "small"
