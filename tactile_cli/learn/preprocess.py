"""Tactile preprocessing that survives drift: per-trial baseline removal, per-window
normalisation and training augmentation (issue 34, item 2).

Between recording sessions a tactile sensor's resting levels move (a BioTac's electrode
and pressure baselines, a taxel's offset) while the texture's vibration and the way the
signals change during a slide stay. A model that reads absolute levels learns the session;
these transforms take the level away, or teach the model to ignore it. All are pure numpy
functions on arrays; :mod:`.data` applies them from the train config's keys
(``data.baseline``, ``data.window_norm``, ``data.augment``), the same way at training,
evaluation and export:

- :func:`baseline_level` / :func:`remove_baseline` (``data.baseline``): each channel of a
  trial minus its resting level: the mean of the trial's first ``duration_ms`` (``mode:
  start``; the level before contact when the recording starts before it, and causal: a
  robot knows it once those milliseconds have passed) or the trial's median (``mode:
  median``; offline only, it needs the whole trial). Applied to samples in sensor units,
  before ``transform`` and the per-channel normalisation.
- :func:`normalise_windows` (``data.window_norm``): each channel of each window centred on
  its own mean (``center``), also divided by its own standard deviation (``zscore``), or
  by its largest absolute deviation (``center_scale``, paper 001 sec. 4). A channel
  constant over its window becomes zeros.
- :func:`augment_windows` (``data.augment``, training only): per window and channel a level
  offset (``offset_sd``, in training standard deviations), a gain of the window's variation
  about its own mean (``gain_sd``, log-normal), a time stretch about the window's centre
  (``time_stretch``: a factor drawn uniformly in ``1 +- time_stretch``, band-limited FFT
  resampling, the edges held) and channel dropout (``channel_dropout``: the channel set
  to 0, the training mean). Every draw comes from the ``numpy.random.Generator`` passed in,
  so a seed gives the same augmented batches.

Level-free summary features of the MLP (``range``, ``diff_std``, ``skew``, ``kurtosis``)
are in :func:`.data.summary_features` and the model's feature layer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: ``data.window_norm`` values, applied per window after the per-channel normalisation.
WINDOW_NORMS: tuple[str, ...] = ("none", "center", "zscore", "center_scale")
#: ``data.baseline.mode`` values.
BASELINE_MODES: tuple[str, ...] = ("none", "start", "median")


def baseline_level(x: np.ndarray, t_s: np.ndarray, *, mode: str, duration_ms: float = 0.0
                   ) -> np.ndarray:
    """(n, c) samples and their (n,) times in seconds -> (c,) float64 resting level of each
    channel: the mean of the samples with ``t_s < t_s[0] + duration_ms / 1000`` (at least
    the first sample) for ``mode="start"``, the median of all samples for ``"median"``,
    zeros for ``"none"`` (and for a trial without samples)."""
    x = np.asarray(x, dtype=np.float64)
    c = x.shape[1] if x.ndim == 2 else 0
    if mode == "none" or x.shape[0] == 0:
        return np.zeros(c)
    if mode == "median":
        return np.median(x, axis=0)
    if mode == "start":
        t = np.asarray(t_s, dtype=np.float64)
        n = max(1, int(np.searchsorted(t, t[0] + duration_ms / 1000.0, side="left")))
        return x[:n].mean(axis=0)
    raise ValueError(f"`mode` (={mode!r}) must be one of {', '.join(BASELINE_MODES)}")


def remove_baseline(x: np.ndarray, t_s: np.ndarray, *, mode: str, duration_ms: float = 0.0
                    ) -> np.ndarray:
    """(n, c) -> (n, c) float32: ``x`` minus :func:`baseline_level` (``x`` itself, as
    float32, for ``mode="none"``)."""
    if mode == "none":
        return np.asarray(x, dtype=np.float32)
    level = baseline_level(x, t_s, mode=mode, duration_ms=duration_ms)
    return (np.asarray(x, dtype=np.float64) - level).astype(np.float32)


def normalise_windows(windows: np.ndarray, mode: str) -> np.ndarray:
    """(k, w, c) -> (k, w, c) float32, each channel of each window: ``none`` unchanged;
    ``center`` minus its mean over the window; ``zscore`` that, divided by its standard
    deviation over the window (population); ``center_scale`` divided by its largest
    absolute deviation instead (spans [-1, 1]). A channel constant over its window (tested
    on its range, not on a float32 spread that rounding can leave above 0) becomes zeros."""
    x = np.asarray(windows, dtype=np.float32)
    if mode == "none":
        return x
    varies = x.max(axis=1, keepdims=True) > x.min(axis=1, keepdims=True)
    centred = x - x.mean(axis=1, keepdims=True)
    if mode == "center":
        return np.where(varies, centred, np.float32(0)).astype(np.float32)
    if mode == "zscore":
        scale = np.sqrt((centred.astype(np.float64) ** 2).mean(axis=1, keepdims=True))
    elif mode == "center_scale":
        scale = np.abs(centred).max(axis=1, keepdims=True)
    else:
        raise ValueError(f"`mode` (={mode!r}) must be one of {', '.join(WINDOW_NORMS)}")
    out = np.zeros_like(centred)
    np.divide(centred, scale.astype(np.float32), out=out, where=varies & (scale > 0))
    return out


# -- augmentation ----------------------------------------------------------------------------
def add_offset(windows: np.ndarray, sd: float, rng: np.random.Generator) -> np.ndarray:
    """(k, w, c) + one N(0, sd) level per window and channel (float32)."""
    x = np.asarray(windows, dtype=np.float32)
    k, _, c = x.shape
    return x + rng.normal(0.0, sd, size=(k, 1, c)).astype(np.float32)


def apply_gain(windows: np.ndarray, sd: float, rng: np.random.Generator) -> np.ndarray:
    """(k, w, c): each channel's variation about its window mean times ``exp(N(0, sd))``,
    one gain per window and channel; the window mean is kept (float32)."""
    x = np.asarray(windows, dtype=np.float32)
    k, _, c = x.shape
    gain = np.exp(rng.normal(0.0, sd, size=(k, 1, c))).astype(np.float32)
    mean = x.mean(axis=1, keepdims=True)
    return mean + gain * (x - mean)


def stretch_time(windows: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """(k, w, c) windows stretched in time about their centre by ``factors`` (k,): each
    window is resampled band-limited (FFT, :func:`scipy.signal.resample`) to ``m =
    round(w / factor)`` samples, so its content moves to ``factor`` times its frequency (a
    factor above 1 is a faster slide), and the centre ``w`` samples are kept (when ``m <
    w`` the edge samples are held outward). Linear interpolation would low-pass the window
    by an amount that changes along it, which a spectrogram model reads as texture; the
    FFT keeps the spectrum. A factor of 1 returns the window (float32)."""
    from scipy.signal import resample  # lazy: scipy only when augmenting

    x = np.asarray(windows, dtype=np.float32)
    k, w, _ = x.shape
    out = np.empty_like(x)
    for j in range(k):  # one FFT per window: each has its own length
        m = max(2, round(w / float(factors[j])))
        if m == w:
            out[j] = x[j]
            continue
        r = resample(x[j].astype(np.float64), m, axis=0)
        shift = round((w - 1) / 2 * (w - m) / w)  # output i <- resampled i - shift
        idx = np.clip(np.arange(w) - shift, 0, m - 1)
        out[j] = r[idx]
    return out


def drop_channels(windows: np.ndarray, p: float, rng: np.random.Generator) -> np.ndarray:
    """(k, w, c): each channel of each window set to 0 (the training mean of a normalised
    channel) with probability ``p`` (float32)."""
    x = np.asarray(windows, dtype=np.float32)
    k, _, c = x.shape
    keep = rng.random(size=(k, 1, c)) >= p
    return np.where(keep, x, np.float32(0)).astype(np.float32)


def augment_windows(windows: np.ndarray, augment: Any, rng: np.random.Generator
                    ) -> np.ndarray:
    """(k, w, c) normalised training windows -> augmented copies (float32), by the
    ``data.augment`` config ``augment`` (:class:`~tactile_cli.learn.config.AugmentConfig`):
    time stretch, gain, level offset, then channel dropout; a zero setting draws nothing.
    The draws come from ``rng`` in that order, so one seed gives the same batches."""
    x = np.asarray(windows, dtype=np.float32)
    if augment.time_stretch > 0:
        a = augment.time_stretch
        x = stretch_time(x, rng.uniform(1.0 - a, 1.0 + a, size=x.shape[0]))
    if augment.gain_sd > 0:
        x = apply_gain(x, augment.gain_sd, rng)
    if augment.offset_sd > 0:
        x = add_offset(x, augment.offset_sd, rng)
    if augment.channel_dropout > 0:
        x = drop_channels(x, augment.channel_dropout, rng)
    return x


__all__ = ["BASELINE_MODES", "WINDOW_NORMS", "add_offset", "apply_gain", "augment_windows",
           "baseline_level", "drop_channels", "normalise_windows", "remove_baseline",
           "stretch_time"]
