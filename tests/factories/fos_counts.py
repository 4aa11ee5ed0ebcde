"""Tactile files of approach-press-slip-release trials with known FOS parameters, for the
fit-fos tests (and :func:`use_test_compilation_cache` for the tests that run the fits).

Each trial's expected net count is :func:`tactile_cli.fos.actions.expected_net_counts`;
the counts per polarity are Poisson around it (positive events carry the positive part of
the net plus ``beta |net|``, negative ones the negative part plus ``beta |net|``, each with
``background`` events), so the net count has mean ``expected`` and variance
``(1 + 2 beta) |expected| + 2 background``. Trials are written either as a
``signals/event_counts`` stream (channels positive, negative, net) or as events (one event
per count, spread uniformly inside its bin), with the four action regions as annotations
and the true parameters as labels (the names of the scene's trials.csv).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
)
from tactile_cli.store import StoreWriter
from tactile_cli.vocabulary import BIN_S


def random_trial(
    rng: np.random.Generator, level: int, *, slip_s: tuple[float, float] = (0.9, 1.2)
) -> tuple[ActionTimeline, FosActionParams]:
    """Timeline and parameters like the paper's (alpha1 in [1365, 2280] by force level,
    tau ~0.3 s, alpha2 ~1615, tau2 ~0.325 s). Press regions of 1.2-1.6 s (at most 96 bins)
    and slips of 0.9-1.2 s (at most 64 bins), like the scene's, so that the tests share one
    compiled solver per model."""
    press_start = rng.uniform(0.3, 0.6)
    press_len = rng.uniform(1.2, 1.6)
    slip_len = rng.uniform(*slip_s)
    release_len = rng.uniform(0.6, 0.8)
    timeline = ActionTimeline(
        press_start_s=press_start,
        slip_start_s=press_start + press_len,
        release_start_s=press_start + press_len + slip_len,
        end_s=press_start + press_len + slip_len + release_len,
        press_duration_s=rng.uniform(0.35, 0.5),
        release_duration_s=0.2,
    )
    alpha = 1365.0 + (2280.0 - 1365.0) * (level - 1) / 11
    params = FosActionParams(
        alpha_press=alpha * rng.uniform(0.97, 1.03),
        tau_press_s=rng.uniform(0.27, 0.33),
        alpha_slip=1615.0 * rng.uniform(0.9, 1.1),
        tau_slip_s=rng.uniform(0.29, 0.36),
        release_gain=0.8,
    )
    return timeline, params


def write_counts_file(
    path: Path,
    *,
    n_trials: int = 12,
    seed: int = 0,
    beta: float = 0.5,
    background: float = 10.0,
    as_events: bool = False,
    annotate: bool = True,
    bin_s: float = BIN_S,
    slip_s: tuple[float, float] = (0.9, 1.2),
) -> list[dict]:
    """Write ``n_trials`` trials to ``path``; returns the true parameters per trial. The
    counts depend only on ``seed`` (events or stream alike)."""
    rng = np.random.default_rng(seed)
    place = np.random.default_rng(seed + 1)  # event positions and times inside the bins
    truth = []
    with StoreWriter(path, command="test") as w:
        if as_events:
            sensor = w.add_sensor("camera", kind="event_camera", sample_rate_hz=0,
                                  width_px=640, height_px=480)
        else:
            sensor = w.add_sensor("event_counts", kind="event_camera", sample_rate_hz=1 / bin_s,
                                  width_px=640, height_px=480,
                                  channel_names=["positive", "negative", "net"],
                                  channel_units="events/bin", bin_s=bin_s)
        for k in range(n_trials):
            level = 1 + k % 12
            timeline, params = random_trial(rng, level, slip_s=slip_s)
            t_s = bin_centres_s(timeline.end_s, bin_s)
            mu = expected_net_counts(t_s, timeline, params)
            spread = beta * np.abs(mu)
            pos = rng.poisson(np.maximum(mu, 0) + spread + background)
            neg = rng.poisson(np.maximum(-mu, 0) + spread + background)
            labels = {"force_level": level, "force_grade": f"grade{(level + 1) // 2}",
                      **params.as_dict(), **timeline.as_dict()}
            trial = w.trial(f"trial_{k:02d}", labels=labels,
                            annotations=timeline.intervals() if annotate else ())
            if as_events:
                counts = np.stack([neg, pos], axis=1).ravel()  # per bin: -1 events, +1 events
                bins = np.repeat(np.arange(len(t_s)), 2)
                pol = np.tile(np.array([-1, 1], np.int8), len(t_s))
                p = np.repeat(pol, counts)
                b = np.repeat(bins, counts)
                t_us = (b * bin_s * 1e6 + place.uniform(0, bin_s * 1e6, len(b))).astype(np.int64)
                order = np.argsort(t_us, kind="stable")
                ev = trial.events(sensor)
                ev.append(place.integers(0, 640, len(b)), place.integers(0, 480, len(b)),
                          t_us[order], p[order])
                ev.close()
                trial.group["events"].attrs["t_origin_us"] = np.int64(0)
            else:
                data = np.stack([pos, neg, pos - neg], axis=1)
                trial.write_signal("event_counts", sensor=sensor, data=data, t_s=t_s,
                                   sample_labels={"action": (timeline.labels(t_s),
                                                             ["approach", "press", "slip",
                                                              "release"])})
            truth.append({"trial": trial.name, "force_level": level, **params.as_dict(),
                          **timeline.as_dict()})
        w.commit()
    return truth


def use_test_compilation_cache() -> None:
    """Point tactile's (and so JAX's) persistent compilation cache at a folder in the system
    temporary directory, so the tests write nothing outside it and later runs skip the XLA
    compilations (the solvers take tens of seconds to compile on a loaded 2-core machine)."""
    import os
    import tempfile

    from tactile_cli.fos.compile_cache import enable_compilation_cache

    os.environ["TACTILE_CACHE_DIR"] = str(Path(tempfile.gettempdir()) / "tactile-tests-cache")
    enable_compilation_cache()
