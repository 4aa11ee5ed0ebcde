"""Synthetic press regions for the grader tests and benchmarks (no events, no scene).

The expected net count per 20 ms bin of the press region is the eq. 16 pulse response of
:func:`tactile_cli.fos.actions.expected_net_counts`, with the scene's facts: 12 force levels
with ``alpha_press`` evenly over [1365, 2280] events/bin, two levels per grade, the top
level optionally flattened by ``limit tanh(net / limit)`` with ``limit = alpha / r``. The
counts per polarity are Poisson (positive ``(1 + beta) net``, negative ``beta net``), plus
optional Gaussian additive noise per bin.
"""

from __future__ import annotations

import numpy as np

from tactile_cli.fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
    saturate,
)

ALPHA_RANGE = (1365.0, 2280.0)
N_LEVELS = 12
LEVELS_PER_GRADE = 2


def level_alpha(level: np.ndarray) -> np.ndarray:
    """alpha_press of force levels 1..12, events per bin."""
    lo, hi = ALPHA_RANGE
    return lo + (hi - lo) * (np.asarray(level, dtype=np.float64) - 1) / (N_LEVELS - 1)


def expected_press(alpha: float, *, duration_s: float = 0.4, region_s: float = 1.2,
                   tau_s: float = 0.3, r: float | None = None) -> np.ndarray:
    """(n_bins,) expected net counts over the press region of one trial."""
    tl = ActionTimeline(0.2, 0.2 + region_s, 0.2 + region_s + 0.5, 0.2 + region_s + 1.0,
                        duration_s)
    pa = FosActionParams(alpha, tau_s, 1615.0, 0.325)
    t = bin_centres_s(tl.end_s)
    y = expected_net_counts(t, tl, pa)
    if r:
        y = saturate(y, alpha / r)
    return y[(t >= tl.press_start_s) & (t < tl.slip_start_s)]


def press_areas(levels: np.ndarray, rng: np.random.Generator, *, beta: float = 0.5,
                noise_std: float = 0.0, top_r: float | None = None,
                alpha_jitter: float = 0.0, duration_spread: float = 0.0,
                duration_s: float = 0.4, **timing) -> np.ndarray:
    """(n,) areas (events) of noisy press regions of trials at force ``levels`` (n,).

    ``noise_std`` additive Gaussian noise per bin (events/bin); ``top_r`` saturation ratio
    of level 12; ``alpha_jitter`` relative per-trial sd of alpha; ``duration_spread`` the
    press duration T drawn uniformly from ``duration_s * (1 +- duration_spread)``."""
    levels = np.asarray(levels)
    out = np.empty(levels.shape[0])
    cache: dict[tuple[int, float, float], np.ndarray] = {}
    for n, level in enumerate(levels):
        jitter = 1.0 + alpha_jitter * rng.standard_normal() if alpha_jitter else 1.0
        dur = duration_s * (1.0 + duration_spread * rng.uniform(-1, 1)) if duration_spread \
            else duration_s
        key = (int(level), jitter, dur)
        if key not in cache:
            r = top_r if int(level) == N_LEVELS else None
            cache[key] = expected_press(float(level_alpha(level)) * jitter, r=r,
                                        duration_s=dur, **timing)
        mu = np.maximum(cache[key], 0.0)
        net = rng.poisson((1 + beta) * mu) - rng.poisson(beta * mu)
        if noise_std:
            net = net + noise_std * rng.standard_normal(mu.shape[0])
        out[n] = net.sum()
    return out


def grades_of(levels: np.ndarray) -> np.ndarray:
    return (np.asarray(levels) - 1) // LEVELS_PER_GRADE
