"""Per-trial decisions and bootstrap intervals over trials.

Windows of one trial are not independent samples: a texture or a grasp outcome is one
answer per trial, and a set of 20 trials shows far less than its 2,000 windows suggest.
So evaluation adds, for classification heads:

- per-trial results for trial-level targets (``source: trial``): each trial's class by
  majority vote of its windows' decisions (ties to the lower class index) and by the
  largest mean softmax probability over its windows;
- 95 % intervals by a bootstrap over trials: trials are drawn with replacement
  (``n_boot`` times, seeded), each draw's windows pooled, and the statistic (window
  accuracy, macro F1 over the classes present in the draw, per-trial accuracy) taken;
  the interval is the 2.5th to 97.5th percentile of the draws.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

N_BOOT = 1000
BOOT_SEED = 0


def per_trial_confusion(y_true: np.ndarray, y_pred: np.ndarray, trial_index: np.ndarray,
                        n_trials: int, n_classes: int) -> np.ndarray:
    """(n_trials, k, k) int64 confusion counts of each trial's windows (rows true)."""
    k = n_classes
    flat = (np.asarray(trial_index, np.int64) * k + np.asarray(y_true, np.int64)) * k \
        + np.asarray(y_pred, np.int64)
    return np.bincount(flat, minlength=n_trials * k * k).reshape(n_trials, k, k)


def _accuracy(cms: np.ndarray) -> np.ndarray:
    """(..., k, k) -> (...) accuracy (NaN where empty)."""
    total = cms.sum(axis=(-2, -1)).astype(np.float64)
    trace = np.trace(cms, axis1=-2, axis2=-1).astype(np.float64)
    return np.divide(trace, total, out=np.full(total.shape, np.nan), where=total > 0)


def macro_f1(cms: np.ndarray) -> np.ndarray:
    """(..., k, k) -> (...) macro F1 over the classes with support (NaN when none)."""
    cms = cms.astype(np.float64)
    tp = np.diagonal(cms, axis1=-2, axis2=-1)
    predicted, actual = cms.sum(axis=-2), cms.sum(axis=-1)
    denom = predicted + actual
    f1 = np.divide(2 * tp, denom, out=np.zeros_like(tp), where=denom > 0)
    present = actual > 0
    n_present = present.sum(axis=-1)
    return np.divide((f1 * present).sum(axis=-1), n_present,
                     out=np.full(n_present.shape, np.nan), where=n_present > 0)


def _draws(n_trials: int, n_boot: int, seed: int) -> np.ndarray:
    """(n_boot, n_trials) how often each trial is drawn in each bootstrap replicate."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_trials, np.full(n_trials, 1.0 / n_trials), size=n_boot)


def _interval(values: np.ndarray) -> list[float] | None:
    v = values[np.isfinite(values)]
    if v.size == 0:
        return None
    lo, hi = np.percentile(v, [2.5, 97.5])
    return [float(lo), float(hi)]


def bootstrap_window_intervals(cms: np.ndarray, *, n_boot: int = N_BOOT,
                               seed: int = BOOT_SEED) -> dict[str, list[float] | None]:
    """95 % intervals of window accuracy and macro F1 from per-trial confusion counts
    (n_trials, k, k); None with fewer than 2 trials."""
    n = cms.shape[0]
    if n < 2:
        return {"accuracy_ci95": None, "macro_f1_ci95": None}
    draws = _draws(n, n_boot, seed)
    pooled = (draws @ cms.reshape(n, -1)).reshape(n_boot, *cms.shape[1:])
    return {"accuracy_ci95": _interval(_accuracy(pooled)),
            "macro_f1_ci95": _interval(macro_f1(pooled))}


@dataclass
class TrialVotes:
    """Per-trial decisions of one classification head over ``n_trials`` trials."""

    n_trials: int
    majority_accuracy: float
    majority_accuracy_ci95: list[float] | None
    mean_probability_accuracy: float
    mean_probability_accuracy_ci95: list[float] | None
    majority_macro_f1: float
    confusion_matrix: list[list[int]]
    """Majority-vote decisions, rows true class, columns predicted."""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _softmax(logits: np.ndarray) -> np.ndarray:
    z = logits - logits.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def trial_votes(y_true: np.ndarray, logits: np.ndarray, trial_index: np.ndarray, *,
                n_boot: int = N_BOOT, seed: int = BOOT_SEED) -> TrialVotes | None:
    """Majority-vote and mean-probability decisions per trial, for a head whose target is
    the same in every window of a trial (None when there is no window). ``logits``:
    (n_windows, k); ``trial_index``: (n_windows,) any integer ids."""
    y_true = np.asarray(y_true, np.int64)
    if y_true.shape[0] == 0:
        return None
    k = logits.shape[1]
    ids, inverse = np.unique(np.asarray(trial_index), return_inverse=True)
    t = ids.shape[0]
    pred = logits.argmax(axis=1)
    votes = np.zeros((t, k), np.int64)
    np.add.at(votes, (inverse, pred), 1)
    prob = np.zeros((t, k))
    np.add.at(prob, inverse, _softmax(logits.astype(np.float64)))
    truth = np.zeros((t, k), np.int64)
    np.add.at(truth, (inverse, y_true), 1)
    true_t = truth.argmax(axis=1)
    majority = votes.argmax(axis=1)
    mean_prob = prob.argmax(axis=1)
    hit_major = (majority == true_t).astype(np.float64)
    hit_prob = (mean_prob == true_t).astype(np.float64)
    cm = np.bincount(true_t * k + majority, minlength=k * k).reshape(k, k)
    ci_major = ci_prob = None
    if t >= 2:
        draws = _draws(t, n_boot, seed).astype(np.float64)
        ci_major = _interval(draws @ hit_major / t)
        ci_prob = _interval(draws @ hit_prob / t)
    return TrialVotes(int(t), float(hit_major.mean()), ci_major, float(hit_prob.mean()), ci_prob,
                      float(macro_f1(cm[None])[0]), cm.tolist())


def fmt_interval(ci: list[float] | None, scale: float = 100.0, digits: int = 1) -> str:
    """``[lo, hi]`` as ``93.1-97.8`` (percent by default), ``n/a`` when None."""
    if ci is None or any(not math.isfinite(v) for v in ci):
        return "n/a"
    return f"{ci[0] * scale:.{digits}f}-{ci[1] * scale:.{digits}f}"


__all__ = ["BOOT_SEED", "N_BOOT", "TrialVotes", "bootstrap_window_intervals", "fmt_interval",
           "macro_f1", "per_trial_confusion", "trial_votes"]
