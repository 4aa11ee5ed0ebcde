"""Synthetic event counts of approach-press-slip-release trials (segmentation, accumulation
and grading tests).

The expected net count is :func:`tactile_cli.fos.actions.expected_net_counts` (optionally
flattened by :func:`~tactile_cli.fos.actions.saturate`); the counts per polarity are
Poisson around it: the positive events carry the positive part of the net plus
``beta |net|``, the negative ones the negative part plus ``beta |net|`` (so
``positive - negative`` has mean ``net`` and ``positive + negative`` mean
``(1 + 2 beta) |net|``), and each polarity gets Poisson background events.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_cli.fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
    saturate,
)
from tactile_cli.vocabulary import BIN_S


@dataclass(frozen=True)
class SynthTrial:
    t_s: np.ndarray
    positive: np.ndarray
    negative: np.ndarray
    expected: np.ndarray
    timeline: ActionTimeline
    params: FosActionParams
    saturation_limit: float | None

    @property
    def net(self) -> np.ndarray:
        return self.positive - self.negative

    @property
    def labels(self) -> np.ndarray:
        return self.timeline.labels(self.t_s)


def random_timeline(rng: np.random.Generator) -> ActionTimeline:
    """Action times of an approach-press-slip-release run, seconds: ranges around the
    marker scene's (configs/scene_marker_events.yaml), widened towards shorter regions."""
    press = rng.uniform(0.3, 0.8)
    press_len = rng.uniform(0.7, 1.4)
    slip_len = rng.uniform(0.5, 1.2)
    release_len = rng.uniform(0.5, 1.0)
    press_duration = rng.uniform(0.25, min(0.6, press_len))
    return ActionTimeline(
        press_start_s=press,
        slip_start_s=press + press_len,
        release_start_s=press + press_len + slip_len,
        end_s=press + press_len + slip_len + release_len,
        press_duration_s=press_duration,
        release_duration_s=rng.uniform(0.1, 0.3),
    )


def random_params(rng: np.random.Generator) -> FosActionParams:
    """FOS parameters around the paper's (alpha1 in [1365, 2280], tau1 ~0.3 s, alpha2
    ~1615, tau2 ~0.325 s), spread wider than the paper's."""
    return FosActionParams(
        alpha_press=rng.uniform(1365, 2280),
        tau_press_s=0.3 * rng.uniform(0.85, 1.15),
        alpha_slip=1615 * rng.uniform(0.9, 1.1),
        tau_slip_s=0.325 * rng.uniform(0.85, 1.15),
        release_gain=rng.uniform(0.6, 1.0),
    )


def make_trial(
    rng: np.random.Generator,
    *,
    timeline: ActionTimeline | None = None,
    params: FosActionParams | None = None,
    beta: float | None = None,
    background: float | None = None,
    alpha_over_limit: float | None = None,
    bin_s: float = BIN_S,
) -> SynthTrial:
    """One noisy trial. ``alpha_over_limit`` r flattens the counts with the limit
    ``alpha_press / r`` as the scene does for its biggest force (None: linear);
    ``beta`` is the opposite-polarity fraction, ``background`` the background events per
    bin of each polarity (both drawn when None)."""
    timeline = timeline or random_timeline(rng)
    params = params or random_params(rng)
    beta = rng.uniform(0.3, 0.8) if beta is None else beta
    background = rng.uniform(5.0, 40.0) if background is None else background
    t_s = bin_centres_s(timeline.end_s, bin_s)
    expected = expected_net_counts(t_s, timeline, params)
    limit = None if alpha_over_limit is None else params.alpha_press / alpha_over_limit
    expected = saturate(expected, limit)
    up, down = np.maximum(expected, 0), np.maximum(-expected, 0)
    spread = beta * np.abs(expected)
    positive = rng.poisson(up + spread + background).astype(np.int64)
    negative = rng.poisson(down + spread + background).astype(np.int64)
    return SynthTrial(t_s, positive, negative, expected, timeline, params, limit)


def events_from_counts(
    positive: np.ndarray, negative: np.ndarray, rng: np.random.Generator, *,
    bin_us: int = 20_000, start_us: int = 0, width: int = 64, height: int = 48,
) -> dict[str, np.ndarray]:
    """Events (t, x, y, p columns, time-sorted) with exactly ``positive[k]`` +1 and
    ``negative[k]`` -1 events in bin k (uniform times inside the bin, from ``start_us``)."""
    counts = np.stack([positive, negative], axis=1).astype(np.int64)
    n_pos, n_neg = int(counts[:, 0].sum()), int(counts[:, 1].sum())
    bins = np.concatenate([np.repeat(np.arange(len(positive)), counts[:, 0]),
                           np.repeat(np.arange(len(negative)), counts[:, 1])])
    p = np.concatenate([np.ones(n_pos, np.int8), -np.ones(n_neg, np.int8)])
    t = start_us + bins * bin_us + rng.integers(0, bin_us, size=bins.size)
    order = np.argsort(t, kind="stable")
    n = bins.size
    return {"t": t[order].astype(np.int64), "p": p[order],
            "x": rng.integers(0, width, n).astype(np.uint16),
            "y": rng.integers(0, height, n).astype(np.uint16)}
