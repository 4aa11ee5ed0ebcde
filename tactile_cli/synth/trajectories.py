"""Random approach-press-slip-release trajectories of net event counts (paper 000, sec. 5.1).

One synthetic trial, drawn with its own random generator (child ``i`` of the seed, so trial
``i`` is the same whatever ``n`` is):

1. a force level, uniformly from the configured levels, and its grade name;
2. FOS parameters from the level's distributions (:mod:`tactile_cli.synth.params`); the press
   length T from them or from ``fos.press_duration_s``; the release gain from the config;
3. a random :class:`~tactile_cli.fos.actions.ActionTimeline`: approach, press region
   (T + ``press_after_s``), slip and release durations and the release pulse length, drawn
   in continuous time, so the bin grid has a random phase against the actions;
4. the expected net count per bin at the bin centres,
   :func:`~tactile_cli.fos.actions.expected_net_counts`, optionally flattened by the
   configured saturation, plus the initial conditions: a constant baseline and an initial
   output that decays with the trial's tau_press;
5. counting noise per polarity (see :class:`~tactile_cli.synth.config.NoiseConfig`): the
   net count is ``k (Poisson(up / k) - Poisson(down / k))`` with mean equal to the expected
   net count.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
    saturate,
)
from .centroids import CentroidModel, CentroidTrajectory, draw_centroids
from .config import SynthConfig
from .params import LevelDistribution


@dataclass(frozen=True)
class SynthTrial:
    """One synthetic trial.

    t_s: (n_bins,) bin centres, s. expected: (n_bins,) expected net events per bin.
    net: (n_bins,) float64 net events per bin with noise. labels: (n_bins,) int8 action
    index per bin (into :data:`tactile_cli.vocabulary.ACTIONS`). centroids: the ROI
    centroid trajectories (:mod:`tactile_cli.synth.centroids`) when requested, else None.
    """

    index: int
    force_level: int
    force_grade: str
    timeline: ActionTimeline
    params: FosActionParams
    baseline_per_bin: float
    initial_state_per_bin: float
    background_per_bin: float
    saturation_limit: float | None
    t_s: np.ndarray
    expected: np.ndarray
    net: np.ndarray
    labels: np.ndarray
    centroids: CentroidTrajectory | None = None

    @property
    def name(self) -> str:
        return f"synth_{self.index:05d}"

    def label_attrs(self) -> dict[str, int | float | str]:
        """Trial labels: the force level and grade and every sampled value (the names of the
        scene's trials.csv where they mean the same)."""
        out: dict[str, int | float | str] = {
            "force_level": self.force_level, "force_grade": self.force_grade,
            **self.params.as_dict(), **self.timeline.as_dict(),
            "baseline_per_bin": self.baseline_per_bin,
            "initial_state_per_bin": self.initial_state_per_bin,
            "background_per_bin": self.background_per_bin,
        }
        if self.saturation_limit is not None:
            out["saturation_limit"] = self.saturation_limit
        if self.centroids is not None:
            out.update(self.centroids.label_attrs())
        return out


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    low, high = bounds
    return float(low if low == high else rng.uniform(low, high))


def noisy_net_counts(
    expected: np.ndarray,
    rng: np.random.Generator,
    *,
    background_per_bin: float,
    opposite_fraction: float,
    counting_scale: float = 1.0,
) -> np.ndarray:
    """(n_bins,) float64 net counts with Poisson-like counting noise around ``expected``.

    Per polarity ``k Poisson(rate / k)`` with the positive rate
    ``(1 + beta) max(mu, 0) + beta max(-mu, 0) + background`` and the negative one mirrored,
    so the net has mean ``mu`` and variance ``k ((1 + 2 beta) |mu| + 2 background)``.
    """
    mu = np.asarray(expected, dtype=np.float64)
    beta, k = opposite_fraction, counting_scale
    up = (1 + beta) * np.maximum(mu, 0) + beta * np.maximum(-mu, 0) + background_per_bin
    down = beta * np.maximum(mu, 0) + (1 + beta) * np.maximum(-mu, 0) + background_per_bin
    return k * (rng.poisson(up / k) - rng.poisson(down / k)).astype(np.float64)


def draw_trial(
    index: int,
    rng: np.random.Generator,
    *,
    config: SynthConfig,
    press: LevelDistribution,
    slip: LevelDistribution,
    grades: Mapping[int, str],
) -> SynthTrial:
    """Draw trial ``index`` with ``rng`` (see the module doc)."""
    levels = config.levels.selected
    level = int(levels[rng.integers(len(levels))])
    p = press.sample(level, rng)
    s = slip.sample(level, rng)
    duration = p.get("press_duration_s")
    if duration is None:
        duration = _uniform(rng, config.fos.press_duration_s)
    timing = config.timing
    press_start = _uniform(rng, timing.approach_s)
    slip_start = press_start + duration + _uniform(rng, timing.press_after_s)
    release_start = slip_start + _uniform(rng, timing.slip_s)
    end = release_start + _uniform(rng, timing.release_s)
    timeline = ActionTimeline(
        press_start_s=press_start, slip_start_s=slip_start, release_start_s=release_start,
        end_s=end, press_duration_s=duration,
        release_duration_s=_uniform(rng, timing.release_duration_s))
    params = FosActionParams(
        alpha_press=p["alpha_press"], tau_press_s=p["tau_press_s"], alpha_slip=s["alpha_slip"],
        tau_slip_s=s["tau_slip_s"], release_gain=_uniform(rng, config.fos.release_gain))
    baseline = _uniform(rng, config.initial.baseline_per_bin)
    state = _uniform(rng, config.initial.state_per_bin)
    background = _uniform(rng, config.noise.background_per_bin)

    t_s = bin_centres_s(end, config.bin_s)
    r = config.saturation.alpha_over_limit.get(level)
    limit = None if r is None else params.alpha_press / r
    expected = (saturate(expected_net_counts(t_s, timeline, params), limit)
                + baseline + state * np.exp(-t_s / params.tau_press_s))
    net = noisy_net_counts(expected, rng, background_per_bin=background,
                           opposite_fraction=config.noise.opposite_fraction,
                           counting_scale=config.noise.counting_scale)
    return SynthTrial(
        index=index, force_level=level,
        force_grade=grades.get(level, config.levels.grade_of(level)), timeline=timeline,
        params=params, baseline_per_bin=baseline, initial_state_per_bin=state,
        background_per_bin=background, saturation_limit=limit, t_s=t_s, expected=expected,
        net=net, labels=timeline.labels(t_s))


def generate_trials(
    n: int,
    *,
    seed: int,
    config: SynthConfig,
    press: LevelDistribution,
    slip: LevelDistribution,
    grades: Mapping[int, str] | None = None,
    centroids: CentroidModel | None = None,
) -> Iterator[SynthTrial]:
    """Yield ``n`` synthetic trials; trial ``i`` uses child ``i`` of ``SeedSequence(seed)``,
    so the same seed gives the same trials and a larger ``n`` only appends trials.

    ``centroids``: also draw each trial's ROI centroid trajectories, from a generator of
    its own (spawned from child ``i``), so the event counts are the same with and without.
    """
    if n < 1:
        raise ValueError(f"`n` (={n}) must be at least 1.")
    if seed < 0:
        raise ValueError(f"`seed` (={seed}) must be >= 0.")
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(n)):
        trial = draw_trial(i, np.random.default_rng(child), config=config, press=press,
                           slip=slip, grades=grades or {})
        if centroids is not None:
            tl = trial.timeline
            trial = replace(trial, centroids=draw_centroids(
                trial.t_s, trial.expected, bin_s=config.bin_s, slip_start_s=tl.slip_start_s,
                release_start_s=tl.release_start_s, tau_press_s=trial.params.tau_press_s,
                background_per_bin=trial.background_per_bin, model=centroids,
                rng=np.random.default_rng(child.spawn(1)[0])))
        yield trial


__all__ = ["SynthTrial", "draw_trial", "generate_trials", "noisy_net_counts"]
