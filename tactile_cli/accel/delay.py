"""Detection delay of slippage (paper 001, sec. 6.5, Fig. 11).

Delay 1: a trained run slides its window over the test recordings with a stride of
``stride`` samples (5 in the paper). For every onset of slippage in the ground truth (a
sample labelled ``slip`` after one that is not), the first window ending at or after the
onset that the run calls ``slip`` gives the number of slip samples it needed; their mean,
at the run's sample rate, is ``delay_samples_ms``. Onsets that are never detected before
the slip ends (or the recording ends) are counted as ``missed`` and left out of the mean;
``missed_long`` counts those among slips lasting at least one window (a slip shorter than
the window, a brief drag or encoder flicker around the 5 cm/s rule, fills little of any
window that ends inside it), and ``delay_long_ms`` is the mean delay 1 over those slips
alone: a slip that resumes after a flicker is often called at once, which pulls the mean
over every onset down.

Delay 2: the measured inference time of one window at batch 1 on this machine's CPU
(median, :func:`tactile_cli.learn.measure_latency`), ``inference_ms``.

``total_ms = delay_samples_ms + inference_ms``. ``motion_accuracy`` is the accuracy of the
motion head over the same windows (every stride-th sample), so the delay is read next to
what the detector gets right.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import InputError
from ..threads import check_threads


@dataclass(frozen=True)
class DelayResult:
    """Detection delay of one run on data (times in ms)."""

    run: str
    delay_samples_ms: float
    delay_samples: float
    inference_ms: float
    total_ms: float
    motion_accuracy: float
    n_onsets: int
    n_detected: int
    n_trials: int
    n_windows: int
    stride: int
    window: int
    sample_rate_hz: float
    threads: int
    per_onset_samples: list[int] = field(default_factory=list)
    n_onsets_long: int = 0
    """Onsets whose slip lasts at least one window (``window`` samples)."""
    n_detected_long: int = 0
    delay_long_ms: float | None = None
    """Mean delay 1 over the detected onsets of those slips (None: none)."""

    def as_dict(self) -> dict[str, Any]:
        out = {k: getattr(self, k) for k in (
            "delay_samples_ms", "inference_ms", "total_ms", "motion_accuracy", "delay_samples",
            "n_onsets", "n_detected", "n_trials", "n_windows", "stride", "window",
            "sample_rate_hz", "threads", "run", "n_onsets_long", "n_detected_long",
            "delay_long_ms")}
        out["missed"] = self.n_onsets - self.n_detected
        out["missed_long"] = self.n_onsets_long - self.n_detected_long
        return out

    def summary(self) -> str:
        """The line ``tactile detect-delay`` prints."""
        long = ("" if self.delay_long_ms is None
                else f", after {self.delay_long_ms:.2f} ms on those")
        return (f"slip detected after {self.delay_samples:.1f} samples = "
                f"{self.delay_samples_ms:.2f} ms (+ inference {self.inference_ms:.2f} ms) = "
                f"{self.total_ms:.2f} ms (mean over the detected onsets); "
                f"{self.n_detected}/{self.n_onsets} onsets detected, "
                f"{self.n_detected_long}/{self.n_onsets_long} of the slips lasting at least "
                f"one window ({self.window} samples){long}; motion accuracy "
                f"{100 * self.motion_accuracy:.1f} % over {self.n_windows} windows (stride "
                f"{self.stride})")


def onset_outcomes(labels: np.ndarray, ends: np.ndarray, predicted: np.ndarray, slip: int
                   ) -> list[tuple[int, int | None]]:
    """``(slip run length, delay)`` in samples for every slip onset of one trial.

    labels: (n,) per-sample class codes of one trial; ends: (k,) increasing last-sample
    index of each window; predicted: (k,) predicted class of each window. An onset is a
    sample labelled ``slip`` whose predecessor is not; its run lasts until the next sample
    that is not ``slip`` (or the trial's end). It is detected by the first window that
    ends inside the same run and is called ``slip``; the delay is that window's last sample
    minus the onset, plus one, or None when no such window exists (missed).
    """
    is_slip = labels == slip
    onsets = np.flatnonzero(is_slip[1:] & ~is_slip[:-1]) + 1
    out: list[tuple[int, int | None]] = []
    for onset in onsets:
        after = np.flatnonzero(~is_slip[onset:])
        stop = onset + (after[0] if after.size else len(labels) - onset)
        sel = (ends >= onset) & (ends < stop) & (predicted == slip)
        out.append((int(stop - onset),
                    int(ends[np.argmax(sel)] - onset + 1) if sel.any() else None))
    return out


def onset_delays(labels: np.ndarray, ends: np.ndarray, predicted: np.ndarray, slip: int
                 ) -> tuple[list[int], int]:
    """(delays in samples of the detected onsets, number of onsets): see
    :func:`onset_outcomes`."""
    outcomes = onset_outcomes(labels, ends, predicted, slip)
    return [d for _, d in outcomes if d is not None], len(outcomes)


def detection_delay(run_dir: str | Path, data_paths: Sequence[str | Path], *, stride: int = 5,
                    split: Literal["all", "test"] = "test", motion: str = "motion",
                    slip_class: str = "slip", threads: int = 1) -> DelayResult:
    """Detection delay of the run ``run_dir`` on ``data_paths`` (see the module docstring).

    ``split="test"``: the trials the run held out for test (for data it never saw: those
    its split rule puts in test); ``"all"``: every trial. Raises :class:`InputError` when
    the run has no classification head ``motion`` with class ``slip_class``, when
    ``stride`` < 1, or when the data hold no slip onset.
    """
    from ..learn import load_run, make_windows, measure_latency, predict, read_trials
    from ..learn.data import check_heads_match, data_files
    from ..learn.runs import SPLIT_CSV
    from ..learn.splits import held_out_trials

    if stride < 1:
        raise InputError(f"`stride` (={stride}) must be >= 1")
    if split not in ("test", "all"):
        raise InputError(f"`split` must be test or all, got {split!r}")
    check_threads(threads, "threads")  # before torch tries to start them
    run = load_run(run_dir)
    head = next((h for h in run.heads if h.name == motion), None)
    if head is None or head.kind != "classification" or slip_class not in head.classes:
        raise InputError(f"the run has no classification head {motion!r} with class "
                         f"{slip_class!r}; train one on the `motion` label", path=run.path)
    paths = data_files(data_paths)
    cfg = run.config
    data = cfg.data.model_copy(update={"stride": stride, "label_rule": "last",
                                       "label_delay": 0})
    trials = read_trials(paths, data, trained=True)
    check_heads_match(run.heads, trials, stream=data.stream)
    if split == "test":
        trials = held_out_trials(trials, split_csv=run.path / SPLIT_CSV, split=data.split,
                                 seed=cfg.seed, targets=data.targets)
        if not trials:
            raise InputError("no trial of these files is in the run's test split; use "
                             "`split='all'` for data the run never saw")
    ws = make_windows(trials, data, run.heads, run.normalisation)
    if len(ws) == 0:
        raise InputError(f"the data give no windows (window {data.window} samples)")
    model = run.load_model()
    pred = predict(model, ws)[motion].argmax(axis=1)
    truth = ws.targets[motion]
    slip = head.classes.index(slip_class)
    outcomes: list[tuple[int, int | None]] = []
    for i, t in enumerate(trials):
        sel = ws.trial_index == i
        outcomes += onset_outcomes(t.sample_labels[motion], ws.end_index[sel], pred[sel], slip)
    delays = [d for _, d in outcomes if d is not None]
    n_onsets = len(outcomes)
    long_runs = [d for n, d in outcomes if n >= data.window]
    long_hits = [d for d in long_runs if d is not None]
    if n_onsets == 0:
        raise InputError("the data hold no slip onset (no sample labelled "
                         f"{slip_class!r} after one that is not)")
    period_s = trials[0].sample_period_s
    rate = 1.0 / period_s
    lat = measure_latency(model, ws.windows(np.arange(min(len(ws), 512))), threads=threads,
                          repeats=200, warmup=20, large_batch=64, large_repeats=2)
    mean_samples = float(np.mean(delays)) if delays else float("nan")
    delay_ms = mean_samples * period_s * 1e3
    return DelayResult(
        run=str(run.path), delay_samples_ms=round(delay_ms, 4),
        delay_samples=round(mean_samples, 3), inference_ms=round(lat.batch1_ms_median, 4),
        total_ms=round(delay_ms + lat.batch1_ms_median, 4),
        motion_accuracy=round(float((pred == truth).mean()), 6), n_onsets=n_onsets,
        n_detected=len(delays), n_trials=len(trials), n_windows=len(ws), stride=stride,
        window=data.window, sample_rate_hz=rate, threads=threads, per_onset_samples=delays,
        n_onsets_long=len(long_runs),
        delay_long_ms=round(float(np.mean(long_hits)) * period_s * 1e3, 4) if long_hits
        else None,
        n_detected_long=sum(d is not None for d in long_runs))
