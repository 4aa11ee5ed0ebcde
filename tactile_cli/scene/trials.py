"""The ground truth of each scene trial: timeline, FOS parameters, saturation and slip speed,
and the expected event rates per bin that follow from them (paper 000, sec. 4.2).

Each trial (group g, force level k) draws from its own generator
``numpy.random.default_rng([seed, g, k])``, so a trial is the same whether it is simulated
alone (``--levels 12``) or in the full scene, and ``--seed`` reproduces every byte.
Values are rounded before use (times to 1 ms, gains to 0.001, time constants to 1 us,
speeds to 1e-6) so the CSV ground truth is exactly what generated the events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
    saturate,
)
from .config import MarkerSceneConfig
from .layout import slip_px_per_m


@dataclass(frozen=True)
class SceneTrial:
    """Ground truth of one trial. Gains are events per bin; times are seconds from the
    trial start; ``saturation_limit`` is ``None`` for a linear trial."""

    name: str
    group: int
    force_level: int
    force_grade: str
    timeline: ActionTimeline
    params: FosActionParams
    saturation_limit: float | None
    slip_speed_m_s: float
    slip_speed_px_s: float
    slip_direction_y: int

    def row(self) -> dict[str, Any]:
        """The trial's row of ``trials.csv`` (column -> value; ``None`` is an empty cell)."""
        tl, pa = self.timeline, self.params
        return {
            "trial": self.name, "group": self.group, "force_level": self.force_level,
            "force_grade": self.force_grade,
            "alpha_press": pa.alpha_press, "tau_press_s": pa.tau_press_s,
            "press_duration_s": tl.press_duration_s, "alpha_slip": pa.alpha_slip,
            "tau_slip_s": pa.tau_slip_s, "release_gain": pa.release_gain,
            "release_duration_s": tl.release_duration_s,
            "saturation_limit": self.saturation_limit,
            "slip_speed_m_s": self.slip_speed_m_s, "slip_speed_px_s": self.slip_speed_px_s,
            "slip_direction_y": self.slip_direction_y,
            "press_start_s": tl.press_start_s, "slip_start_s": tl.slip_start_s,
            "release_start_s": tl.release_start_s, "end_s": tl.end_s,
        }


@dataclass(frozen=True)
class TrialRates:
    """Expected events per bin of one trial.

    t_s: (n_bins,) bin centres, s; net: (n_bins,) expected net (positive - negative) signal
    events after saturation; positive, negative: (n_bins,) expected signal events of each
    polarity (strips and markers), without background; background: expected background
    events per bin of each polarity (scalar).
    """

    t_s: np.ndarray
    net: np.ndarray
    positive: np.ndarray
    negative: np.ndarray
    background: float
    bin_s: float


def trial_name(group: int, level: int) -> str:
    """``g1_level01``: the trial's file stem and name in the ingested file."""
    return f"g{group}_level{level:02d}"


def trial_rng(seed: int, group: int, level: int) -> np.random.Generator:
    """The generator of trial (group, level) for ``seed`` (>= 0)."""
    return np.random.default_rng([seed, group, level])


def _jitter(value: float, rel: float, rng: np.random.Generator) -> float:
    return value * (1.0 + rel * float(np.clip(rng.standard_normal(), -3.0, 3.0)))


def _ms(range_s: tuple[float, float], rng: np.random.Generator) -> int:
    """A duration in whole milliseconds drawn uniformly from ``range_s`` (seconds)."""
    lo, hi = math.ceil(range_s[0] * 1000 - 1e-9), math.floor(range_s[1] * 1000 + 1e-9)
    return int(rng.integers(lo, max(lo, hi) + 1))


def draw_trial(config: MarkerSceneConfig, group: int, level: int,
               rng: np.random.Generator) -> SceneTrial:
    """Draw the ground truth of trial (group, level) from ``rng`` (advances it)."""
    tm, fos = config.timing, config.fos
    approach, press_region, press_t = (_ms(tm.approach_s, rng), _ms(tm.press_region_s, rng),
                                       _ms(tm.press_duration_s, rng))
    slip, release, release_t = (_ms(tm.slip_s, rng), _ms(tm.release_s, rng),
                                _ms(tm.release_duration_s, rng))
    press_ms = approach
    slip_ms = press_ms + press_region
    release_ms = slip_ms + slip
    bin_us = config.bin_us
    end_us = -(-(release_ms + release) * 1000 // bin_us) * bin_us  # whole bins
    press_start_s, slip_start_s = press_ms / 1000, slip_ms / 1000
    timeline = ActionTimeline(
        press_start_s=press_start_s,
        slip_start_s=slip_start_s,
        release_start_s=release_ms / 1000,
        end_s=end_us / 1e6,
        press_duration_s=min(press_t / 1000, slip_start_s - press_start_s),
        release_duration_s=release_t / 1000,
    )
    lo, hi = fos.alpha_press_range
    n = config.trials.n_levels
    alpha_level = lo + (hi - lo) * (level - 1) / (n - 1) if n > 1 else hi
    params = FosActionParams(
        alpha_press=round(_jitter(alpha_level, fos.alpha_press_jitter_rel, rng), 3),
        tau_press_s=round(_jitter(fos.tau_press_s, fos.tau_press_jitter_rel, rng), 6),
        alpha_slip=round(_jitter(fos.alpha_slip, fos.alpha_slip_jitter_rel, rng), 3),
        tau_slip_s=round(_jitter(fos.tau_slip_s, fos.tau_slip_jitter_rel, rng), 6),
        release_gain=round(_jitter(fos.release_gain, fos.release_gain_jitter_rel, rng), 4),
    )
    ratio = config.saturation.alpha_over_limit.get(level)
    limit = None if ratio is None else round(params.alpha_press / ratio, 3)
    speeds = config.slip.speeds_m_s
    speed = speeds[(group - 1 + level - 1) % len(speeds)]
    s = config.sensor
    px_per_m = slip_px_per_m(focal_length_m=s.focal_length_m,
                             strip_distance_m=s.strip_distance_m, pixel_pitch_m=s.pixel_pitch_m)
    return SceneTrial(
        name=trial_name(group, level), group=group, force_level=level,
        force_grade=config.trials.grade_of(level), timeline=timeline, params=params,
        saturation_limit=limit, slip_speed_m_s=speed,
        slip_speed_px_s=round(speed * px_per_m, 6), slip_direction_y=config.slip.direction_y,
    )


def plan_trials(config: MarkerSceneConfig, *, seed: int) -> list[SceneTrial]:
    """The ground truth of every trial of the scene, groups outer, levels inner (the same
    values :func:`~tactile_cli.scene.simulate_marker_events` uses)."""
    return [draw_trial(config, g, k, trial_rng(seed, g, k))
            for g in range(1, config.trials.groups + 1) for k in config.trials.selected_levels]


def expected_rates(trial: SceneTrial, config: MarkerSceneConfig) -> TrialRates:
    """Expected events per bin of ``trial``: eqs. 16-17 via
    :func:`~tactile_cli.fos.actions.expected_net_counts`, saturated, split by polarity."""
    t_s = bin_centres_s(trial.timeline.end_s, config.bin_s)
    net = saturate(expected_net_counts(t_s, trial.timeline, trial.params),
                   trial.saturation_limit)
    beta = config.polarity.opposite_fraction
    up, down = np.maximum(net, 0.0), np.maximum(-net, 0.0)
    return TrialRates(
        t_s=t_s, net=net,
        positive=(1.0 + beta) * up + beta * down,
        negative=beta * up + (1.0 + beta) * down,
        background=config.noise.background_rate_hz * config.bin_s / 2.0,
        bin_s=config.bin_s,
    )


__all__ = ["SceneTrial", "TrialRates", "draw_trial", "plan_trials", "expected_rates",
           "trial_name", "trial_rng"]
