"""The trigger logic of paper 003 (sec. 2.4), arrays in and arrays out.

One rule serves every sensor: a calibration buffer at the start gives a reference and a
noise level; a moving average of the deviation from the reference is the level; the
trigger is on while the level exceeds a threshold, and its rising edges (closer ones
merged) are the detected events.

- peak amplitude in a band (contact with an object): reference 0, noise level = the mean
  amplitude in the calibration buffer, threshold ``2 x`` that (sec. 2.4);
- force (contact): reference = calibration mean, noise level = mean |deviation| there
  (about 0.015 N for the HEX21), threshold ``1.6 x`` that; for touches 0.3 N (sec. 2.4.2);
- peak frequency in a band (a touch on a grasped object): reference = calibration mean,
  deviation relative to it, threshold 3 % (sec. 2.4.2).

:class:`StreamingTrigger` applies the same rule one value at a time (``--follow``).
:func:`band_scores` ranks candidate bands by how well their peak amplitude separates
contact from the gripper's motion (the band-finder).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ..spectral import causal_moving_average


@dataclass(frozen=True)
class Trigger:
    """A trigger over one signal: ``t_s`` (n,) seconds, ``raw`` (n,) the values, ``level``
    (n,) the averaged |deviation|, ``reference`` and ``noise`` from the calibration
    buffer, ``threshold`` (in the level's unit), ``on`` (n,) bool, and ``events``: (start_s,
    end_s) of each trigger (rising edge to falling edge, close ones merged)."""

    t_s: np.ndarray
    raw: np.ndarray
    level: np.ndarray
    reference: float
    noise: float
    threshold: float
    on: np.ndarray
    events: list[tuple[float, float]]

    def first_after(self, t_s: float) -> float | None:
        """Start of the first event at or after ``t_s``, or None."""
        for start, _ in self.events:
            if start >= t_s:
                return start
        return None

    def count_between(self, lo_s: float, hi_s: float) -> int:
        """Events that start in [lo_s, hi_s)."""
        return sum(1 for start, _ in self.events if lo_s <= start < hi_s)

    def snr(self, start_s: float, window_s: float) -> float | None:
        """Highest level in [start_s, start_s + window_s) over the noise level (None when
        the window holds no value or the noise level is 0)."""
        inside = (self.t_s >= start_s) & (self.t_s < start_s + window_s)
        if not inside.any() or self.noise <= 0:
            return None
        return float(self.level[inside].max() / self.noise)


def events_from(t_s: np.ndarray, on: np.ndarray, merge_s: float) -> list[tuple[float, float]]:
    """(start_s, end_s) runs of ``on`` (n,) bool at times ``t_s`` (n,); a run starting less
    than ``merge_s`` after the previous one ended extends it."""
    if len(on) == 0:
        return []
    edges = np.diff(np.concatenate([[0], on.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    out: list[tuple[float, float]] = []
    for a, b in zip(starts, ends, strict=True):
        start, end = float(t_s[a]), float(t_s[b])
        if out and start - out[-1][1] < merge_s:
            out[-1] = (out[-1][0], end)
        else:
            out.append((start, end))
    return out


def threshold_trigger(t_s: np.ndarray, values: np.ndarray, *, calibration_s: float,
                      average: int, factor: float | None = None,
                      threshold: float | None = None, centre: bool = True,
                      relative: bool = False, merge_s: float = 0.3) -> Trigger:
    """The trigger of the module docstring over ``values`` (n,) at ``t_s`` (n,) seconds.

    ``centre``: deviations from the calibration mean (else from 0); ``relative``: divided
    by that mean. Exactly one of ``factor`` (times the noise level) and ``threshold`` (in
    the level's unit). The trigger is never on inside the calibration buffer.
    """
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(values, dtype=np.float64)
    if (factor is None) == (threshold is None):
        raise ValueError("give exactly one of `factor` and `threshold`")
    cal = t <= t[0] + calibration_s if len(t) else np.zeros(0, bool)
    if not cal.any() or cal.all():
        raise ValueError(f"`calibration_s` (={calibration_s}) must leave values both inside "
                         f"and after the calibration buffer (recording: "
                         f"{(t[-1] - t[0]) if len(t) else 0:.3g} s)")
    reference = float(x[cal].mean()) if centre else 0.0
    scale = abs(reference) if relative and reference != 0 else 1.0
    dev = (x - reference) / scale
    noise = float(np.abs(dev[cal]).mean())
    level = np.abs(causal_moving_average(x, average) - reference) / scale
    thr = float(factor * noise) if factor is not None else float(threshold)  # type: ignore[arg-type]
    on = (level > thr) & ~cal
    return Trigger(t, x, level, reference, noise, thr, on, events_from(t, on, merge_s))


class StreamingTrigger:
    """:func:`threshold_trigger` one value at a time: :meth:`update` returns whether the
    trigger is on after that value (False during calibration). Equal, value for value, to
    the offline trigger on the same values."""

    def __init__(self, *, calibration_s: float, average: int, factor: float | None = None,
                 threshold: float | None = None, centre: bool = True,
                 relative: bool = False):
        if (factor is None) == (threshold is None):
            raise ValueError("give exactly one of `factor` and `threshold`")
        self.calibration_s, self.factor, self.fixed = calibration_s, factor, threshold
        self.centre, self.relative = centre, relative
        self._recent: deque[float] = deque(maxlen=average)
        self._calibration: list[float] = []
        self._t0: float | None = None
        self.reference: float | None = None
        self.noise: float | None = None
        self.threshold: float | None = None
        self.level = float("nan")

    def _calibrate(self) -> None:
        x = np.asarray(self._calibration)
        self.reference = float(x.mean()) if self.centre else 0.0
        scale = abs(self.reference) if self.relative and self.reference != 0 else 1.0
        self._scale = scale
        self.noise = float(np.abs((x - self.reference) / scale).mean())
        self.threshold = (self.factor * self.noise if self.factor is not None
                          else float(self.fixed))  # type: ignore[arg-type]
        self._calibration = []

    def update(self, t_s: float, value: float) -> bool:
        if self._t0 is None:
            self._t0 = t_s
        self._recent.append(float(value))
        if t_s <= self._t0 + self.calibration_s:
            self._calibration.append(float(value))
            return False
        if self.reference is None:
            self._calibrate()
        mean = sum(self._recent) / len(self._recent)
        self.level = abs(mean - self.reference) / self._scale  # type: ignore[operator]
        return self.level > self.threshold  # type: ignore[operator]


def band_scores(amplitudes: list[np.ndarray], t_s: list[np.ndarray], contact_s: list[float],
                f_hz: np.ndarray, *, width_hz: float, calibration_s: float, average: int,
                window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Score every band ``[f, f + width_hz]`` (f on the bin grid ``f_hz``) as a contact
    detector over labelled recordings: per recording, the band's averaged peak amplitude
    after contact (``window_s`` long) and its highest value before contact (the gripper
    moving), both over the calibration buffer's mean amplitude; the score is the median
    over recordings of ``after / max(before, 1)``.

    amplitudes: per recording (n_frames, n_bins) amplitude spectra; t_s: their (n_frames,)
    frame times; contact_s: the true contact time of each. Returns (band starts (n_bands,)
    Hz, scores (n_bands,)).
    """
    from scipy.ndimage import maximum_filter1d

    f = np.asarray(f_hz, dtype=np.float64)
    step = f[1] - f[0]
    width = max(1, int(round(width_hz / step)) + 1)
    n_bands = len(f) - width + 1
    if n_bands < 1:
        raise ValueError(f"`width_hz` (={width_hz}) is wider than the spectrum")
    ratios = []
    for mag, t, contact in zip(amplitudes, t_s, contact_s, strict=True):
        # peak amplitude in each band: a running maximum over `width` bins
        peak = maximum_filter1d(mag, size=width, axis=1, origin=-(width // 2))[:, :n_bands]
        c = np.cumsum(np.vstack([np.zeros((1, n_bands)), peak]), axis=0)
        k = np.arange(1, len(peak) + 1)
        lo = np.maximum(0, k - average)
        avg = (c[k] - c[lo]) / (k - lo)[:, None]
        cal = t <= t[0] + calibration_s
        noise = np.maximum(peak[cal].mean(axis=0), 1e-300)
        before = (t > t[0] + calibration_s) & (t < contact)
        after = (t >= contact) & (t < contact + window_s)
        if not cal.any() or not after.any():
            continue
        worst = avg[before].max(axis=0) / noise if before.any() else np.ones(n_bands)
        ratios.append(avg[after].mean(axis=0) / noise / np.maximum(worst, 1.0))
    if not ratios:
        raise ValueError("no recording holds both a calibration buffer and frames after its "
                         "contact")
    return f[:n_bands], np.median(np.array(ratios), axis=0)
