"""Synthetic action-classification recordings for the learn tests (and target measurements).

Files shaped like `tactile synth` output (contract 3): per trial a
``signals/event_counts`` stream with the one channel ``net`` (events per 20 ms bin) drawn
from :func:`tactile_cli.fos.actions.expected_net_counts` with Poisson counting noise,
a random :class:`ActionTimeline`, press gain alpha over [1365, 2280] by force level
(paper 000, sec. 4.2), per-bin ``sample_labels/action`` and trial labels ``force_level``
and ``force_grade``. :func:`make_event_file` writes the same trials as raw events with
annotations and no counts stream, like an ingested scene recording.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_cli.fos.actions import (
    ActionTimeline,
    FosActionParams,
    bin_centres_s,
    expected_net_counts,
)
from tactile_cli.store import StoreWriter
from tactile_cli.vocabulary import ACTIONS

ALPHA_PRESS = np.linspace(1365.0, 2280.0, 12)
GRADES = ("light", "small", "small_medium", "medium", "small_big", "big")


@dataclass
class ActionTrial:
    t_s: np.ndarray  # (n,) bin centres
    positive: np.ndarray  # (n,) int64 events per bin
    negative: np.ndarray
    labels: np.ndarray  # (n,) int8 action index
    timeline: ActionTimeline
    params: FosActionParams
    level: int

    @property
    def net(self) -> np.ndarray:
        return self.positive - self.negative


def action_trial(rng: np.random.Generator, *, level: int, bin_s: float = 0.02,
                 background: float = 5.0, scale: float = 1.0) -> ActionTrial:
    """One random approach-press-slip-release trial; ``scale`` multiplies every gain."""
    press_start = rng.uniform(0.3, 1.0)
    press_len = rng.uniform(0.8, 1.5)
    slip_len = rng.uniform(0.8, 1.5)
    release_len = rng.uniform(0.6, 1.2)
    timeline = ActionTimeline(
        press_start_s=press_start,
        slip_start_s=press_start + press_len,
        release_start_s=press_start + press_len + slip_len,
        end_s=press_start + press_len + slip_len + release_len,
        press_duration_s=press_len * rng.uniform(0.5, 0.9),
    )
    params = FosActionParams(
        alpha_press=scale * ALPHA_PRESS[level - 1] * rng.uniform(0.97, 1.03),
        tau_press_s=0.3 * rng.uniform(0.9, 1.1),
        alpha_slip=scale * 1615.0 * rng.uniform(0.9, 1.1),
        tau_slip_s=0.325 * rng.uniform(0.9, 1.1),
    )
    t_s = bin_centres_s(timeline.end_s, bin_s)
    mu = expected_net_counts(t_s, timeline, params)
    positive = rng.poisson(np.maximum(mu, 0.0) + background)
    negative = rng.poisson(np.maximum(-mu, 0.0) + background)
    return ActionTrial(t_s, positive, negative, timeline.labels(t_s), timeline, params, level)


def make_action_file(path: Path, *, n_trials: int = 24, seed: int = 0, bin_s: float = 0.02,
                     splits: Sequence[str] | None = None, sample_rate_hz: float | None = None,
                     channel_names: Sequence[str] = ("net",),
                     channel_units: str | Sequence[str] = "events/bin") -> Path:
    """A counts file like `tactile synth` writes: ``n_trials`` trials cycling through the
    12 force levels; ``splits`` sets each trial's split attribute.

    The same seed gives the same counts whatever the rest: ``sample_rate_hz`` overrides the
    sensor's rate attribute (default ``1 / bin_s``) without changing the data;
    ``channel_names`` names the columns (``positive`` and ``negative`` hold those counts,
    any other name the net counts) and ``channel_units`` their units."""
    rng = np.random.default_rng(seed)
    rate = 1 / bin_s if sample_rate_hz is None else sample_rate_hz
    with StoreWriter(path, command="tests.factories.action_files") as w:
        s = w.add_sensor("event_counts", kind="event_camera", sample_rate_hz=rate,
                         width_px=640, height_px=480, channel_names=list(channel_names),
                         channel_units=channel_units, bin_s=bin_s)
        for i in range(n_trials):
            level = i % 12 + 1
            tr = action_trial(rng, level=level, bin_s=bin_s)
            trial = w.trial(f"synth_{i:04d}", split=splits[i] if splits else "",
                            labels={"force_level": level, "force_grade": GRADES[(level - 1) // 2]})
            columns = {"positive": tr.positive, "negative": tr.negative}
            data = np.stack([columns.get(c, tr.net) for c in channel_names], axis=1)
            trial.write_signal("event_counts", sensor=s, data=data.astype(np.float32),
                               t_s=tr.t_s, sample_labels={"action": (tr.labels.astype(np.int8),
                                                                     ACTIONS)})
        w.commit()
    return path


def make_event_file(path: Path, *, n_trials: int = 2, seed: int = 1, scale: float = 0.05,
                    bin_s: float = 0.02) -> tuple[Path, list[ActionTrial]]:
    """Raw-event trials (ingested-scene shape: events, annotations, no counts stream);
    gains scaled by ``scale`` to keep the files small. Returns the ground truth too."""
    rng = np.random.default_rng(seed)
    truth = []
    with StoreWriter(path, command="tests.factories.action_files") as w:
        w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=640, height_px=480)
        for i in range(n_trials):
            level = i % 12 + 1
            tr = action_trial(rng, level=level, bin_s=bin_s, background=1.0, scale=scale)
            truth.append(tr)
            trial = w.trial(f"scene_{i:03d}", annotations=tr.timeline.intervals(),
                            labels={"force_level": level})
            bin_us = round(bin_s * 1e6)
            t, p = [], []
            for k in range(tr.t_s.shape[0]):
                for pol, n in ((1, tr.positive[k]), (-1, tr.negative[k])):
                    t.append(k * bin_us + rng.integers(0, bin_us, n))
                    p.append(np.full(n, pol, np.int8))
            t_us = np.concatenate(t)
            order = np.argsort(t_us, kind="stable")
            t_us, pol_all = t_us[order], np.concatenate(p)[order]
            n_ev = t_us.shape[0]
            ev = trial.events("dvs")
            ev.append(rng.integers(0, 640, n_ev), rng.integers(0, 480, n_ev), t_us, pol_all)
            ev.close()
            ev.group.attrs["t_origin_us"] = np.int64(0)
        w.commit()
    return path, truth
