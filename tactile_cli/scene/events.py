"""Expected rates per bin -> one trial's address events (t, x, y, p), vectorised.

Per bin k the scene has four independent Poisson sources: strip (positive) and marker
(negative) signal events with the expected counts of :class:`~tactile_cli.scene.trials.
TrialRates`, and background events of each polarity. Their sum is Poisson, and given the
total each event's source is a categorical draw with probabilities proportional to the
rates, so the scene draws one Poisson total per bin and one category per event: the same
distribution as four separate draws, without a sort.

Times are uniform within their bin and come out sorted: the sorted uniforms of a bin with
``n`` events are the normalised partial sums of ``n + 1`` exponential draws (order
statistics of the uniform distribution), which costs O(n) instead of a sort.

Space: strip events are uniform over their strip's band, whose centre moves along y at the
trial's slip speed during the slip and relaxes back with tau_1 after the release; marker
events are uniform over a marker disc; background events are uniform over the sensor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .layout import SceneLayout
from .trials import SceneTrial, TrialRates

#: One event: t int64 us from the trial start, x/y uint16 px, p int8 -1/+1 (packed, 13 B).
EVENT_DTYPE = np.dtype([("t", "<i8"), ("x", "<u2"), ("y", "<u2"), ("p", "i1")])

STRIP, MARKER, BACKGROUND_ON, BACKGROUND_OFF = 0, 1, 2, 3


@dataclass(frozen=True)
class SimulatedEvents:
    """events: (n,) :data:`EVENT_DTYPE` sorted by t; counts of each source."""

    events: np.ndarray
    n_strip: int
    n_marker: int
    n_background: int

    @property
    def n_events(self) -> int:
        return int(self.events.shape[0])

    @property
    def n_positive(self) -> int:
        return int(np.count_nonzero(self.events["p"] > 0))

    @property
    def n_negative(self) -> int:
        return self.n_events - self.n_positive


def strip_offset_px(t_s: np.ndarray, trial: SceneTrial) -> np.ndarray:
    """(n,) displacement of the strip bands along y at times ``t_s`` (s), px: zero before
    the slip, ``direction * speed * (t - slip_start)`` during it, then an exponential return
    with tau_1 (the press time constant) after the release."""
    tl = trial.timeline
    velocity = trial.slip_direction_y * trial.slip_speed_px_s
    slip_len = tl.release_start_s - tl.slip_start_s
    moved = velocity * np.clip(t_s - tl.slip_start_s, 0.0, slip_len)
    since_release = np.maximum(t_s - tl.release_start_s, 0.0)
    return moved * np.exp(-since_release / trial.params.tau_press_s)


def trial_events(trial: SceneTrial, rates: TrialRates, layout: SceneLayout,
                 rng: np.random.Generator) -> SimulatedEvents:
    """Draw the events of one trial from ``rng`` (advances it)."""
    n_bins = rates.t_s.shape[0]
    bin_us = round(rates.bin_s * 1e6)
    bg = rates.background
    # cumulative rate thresholds of the four sources per bin
    c0 = rates.positive
    c1 = c0 + rates.negative
    c2 = c1 + bg
    total = c2 + bg
    counts = rng.poisson(total)
    n = int(counts.sum())
    bins = np.repeat(np.arange(n_bins), counts)

    # sorted uniform times within each bin: partial sums of n_k + 1 exponentials per bin
    e = np.cumsum(rng.standard_exponential(n + n_bins))
    seg_last = np.cumsum(counts + 1) - 1  # index of each bin's extra exponential
    seg_before = np.concatenate(([0.0], e[seg_last[:-1]]))  # partial sum before each bin
    idx = np.arange(n) + bins  # position of each event's exponential in e
    start = seg_before[bins]
    u = (e[idx] - start) / (e[seg_last[bins]] - start)
    offset_us = np.minimum((u * bin_us).astype(np.int64), bin_us - 1)
    t_us = bins.astype(np.int64) * bin_us + offset_us

    v = rng.random(n) * total[bins]
    source = ((v >= c0[bins]).astype(np.int8) + (v >= c1[bins]) + (v >= c2[bins])).astype(
        np.int8)

    x = np.empty(n, dtype=np.uint16)
    y = np.empty(n, dtype=np.uint16)
    p = np.where((source == STRIP) | (source == BACKGROUND_ON), np.int8(1), np.int8(-1))

    strip = np.flatnonzero(source == STRIP)
    k = strip.size
    which = rng.integers(0, layout.strip_x0_px.size, size=k)
    x[strip] = layout.strip_x0_px[which] + np.floor(
        rng.random(k) * layout.strip_width_px).astype(np.int64)
    centre = layout.strip_rest_y_px + strip_offset_px(t_us[strip] * 1e-6, trial)
    y[strip] = np.floor(centre + (rng.random(k) - 0.5) * layout.band_height_px).astype(np.int64)

    marker = np.flatnonzero(source == MARKER)
    k = marker.size
    which = rng.integers(0, layout.marker_xy_px.shape[0], size=k)
    radius = layout.marker_radius_px * np.sqrt(rng.random(k))
    angle = 2.0 * np.pi * rng.random(k)
    x[marker] = np.floor(layout.marker_xy_px[which, 0] + radius * np.cos(angle)).astype(np.int64)
    y[marker] = np.floor(layout.marker_xy_px[which, 1] + radius * np.sin(angle)).astype(np.int64)

    noise = np.flatnonzero(source >= BACKGROUND_ON)
    k = noise.size
    x[noise] = rng.integers(0, layout.width_px, size=k)
    y[noise] = rng.integers(0, layout.height_px, size=k)

    events = np.empty(n, dtype=EVENT_DTYPE)
    events["t"] = t_us
    events["x"] = x
    events["y"] = y
    events["p"] = p
    return SimulatedEvents(events, n_strip=int(strip.size), n_marker=int(marker.size),
                       n_background=int(k))


__all__ = ["EVENT_DTYPE", "SimulatedEvents", "strip_offset_px", "trial_events"]
