"""Sliding spectra and band tracking of one sampled channel, offline or as samples arrive.

Paper 003 (sec. 2.4) refreshes a spectrogram of the accelerometer at 100 Hz and follows,
in one frequency band, the peak amplitude (contact with an object) or the peak frequency
(a touch on a grasped object), smoothed by a moving average. Any stream can enter these:

- :func:`frame_spectra`: Hann-windowed amplitude spectra of frames ``window_s`` long every
  ``hop_s`` (each frame stamped with the time of its last sample, so that a detection never
  uses samples from its future);
- :func:`band_peak`: the peak amplitude and the peak frequency (parabolic interpolation
  between bins) in a band of each frame;
- :func:`causal_moving_average`: the causal trailing mean;
- :class:`SpectrumTracker`: the same frames from samples pushed in chunks of any size
  (``tactile detect-contact --follow``); frame for frame equal to :func:`frame_spectra`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FrameSettings:
    """Frames of ``window`` samples every ``hop`` samples, each zero-padded to ``n_fft``."""

    rate_hz: float
    window: int
    hop: int
    n_fft: int

    @classmethod
    def from_seconds(cls, rate_hz: float, *, window_s: float, hop_s: float,
                     n_fft: int | None = None) -> FrameSettings:
        """Settings from durations (rounded to whole samples); ``n_fft`` defaults to the
        next power of two at or above the window."""
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"`rate_hz` (={rate_hz}) must be positive")
        if not (np.isfinite(window_s) and np.isfinite(hop_s)):
            raise ValueError(f"`window_s` (={window_s}) and `hop_s` (={hop_s}) must be finite")
        window = int(round(window_s * rate_hz))
        hop = int(round(hop_s * rate_hz))
        if window < 4:
            raise ValueError(f"`window_s` (={window_s}) must span at least 4 samples")
        if hop < 1:
            raise ValueError(f"`hop_s` (={hop_s}) must span at least 1 sample")
        n = 1 << (window - 1).bit_length() if n_fft is None else int(n_fft)
        if n < window:
            raise ValueError(f"`n_fft` (={n}) must be at least the window (={window} samples)")
        return cls(float(rate_hz), window, hop, n)

    @property
    def f_hz(self) -> np.ndarray:
        """(n_fft // 2 + 1,) bin frequencies, Hz."""
        return np.fft.rfftfreq(self.n_fft, 1.0 / self.rate_hz)

    @property
    def taper(self) -> np.ndarray:
        """(window,) Hann taper scaled so that a sine of amplitude A peaks at A."""
        w = np.hanning(self.window + 2)[1:-1]
        return w * (2.0 / w.sum())


@dataclass(frozen=True)
class FrameSpectra:
    """``t_s`` (n_frames,) time of each frame's last sample (seconds from the first sample),
    ``f_hz`` (n_bins,), ``magnitude`` (n_frames, n_bins) amplitude in the input's unit."""

    t_s: np.ndarray
    f_hz: np.ndarray
    magnitude: np.ndarray


def frame_spectra(x: np.ndarray, settings: FrameSettings) -> FrameSpectra:
    """Amplitude spectra of the (n_samples,) signal ``x`` in frames of ``settings`` (the
    frame mean removed). Frames start at 0, hop, 2 hop, ... and end inside the signal."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"`x` must be one channel (n_samples,), got shape {x.shape}")
    n_frames = 0 if len(x) < settings.window else 1 + (len(x) - settings.window) // settings.hop
    starts = np.arange(n_frames) * settings.hop
    rows = []
    step = max(1, (1 << 22) // max(1, settings.n_fft))  # bounded memory for long signals
    for lo in range(0, n_frames, step):
        idx = starts[lo:lo + step, None] + np.arange(settings.window)
        frames = x[idx]
        frames = frames - frames.mean(axis=1, keepdims=True)
        rows.append(np.abs(np.fft.rfft(frames * settings.taper, n=settings.n_fft, axis=1)))
    mag = np.concatenate(rows) if rows else np.zeros((0, settings.n_fft // 2 + 1))
    t = (starts + settings.window - 1) / settings.rate_hz
    return FrameSpectra(t, settings.f_hz, mag)


def band_peak(magnitude: np.ndarray, f_hz: np.ndarray, band_hz: tuple[float, float], *,
              local: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Peak amplitude (n_frames,) and peak frequency (n_frames,) Hz within ``band_hz``
    (inclusive) of (n_frames, n_bins) spectra; the frequency is refined by a parabola
    through the log-amplitudes of the peak bin and its neighbours.

    ``local``: the highest local maximum of the spectrum inside the band (a resonance),
    not the skirt of a stronger line outside it that rises towards a band edge; frames
    without one fall back to the band's maximum."""
    lo, hi = float(band_hz[0]), float(band_hz[1])
    f = np.asarray(f_hz, dtype=np.float64)
    inside = np.flatnonzero((f >= lo) & (f <= hi))
    if not lo < hi or len(inside) == 0:
        raise ValueError(f"`band_hz` (={[lo, hi]}) must be an increasing pair that holds at "
                         f"least one frequency bin (bins every {f[1] - f[0]:.3g} Hz up to "
                         f"{f[-1]:g} Hz)")
    mag = np.asarray(magnitude, dtype=np.float64)
    if mag.ndim == 1:
        mag = mag[None]
    sub = mag[:, inside]
    if local:
        left_n = mag[:, np.maximum(inside - 1, 0)]
        right_n = mag[:, np.minimum(inside + 1, mag.shape[1] - 1)]
        is_max = (sub >= left_n) & (sub >= right_n)
        masked = np.where(is_max, sub, -np.inf)
        k = np.where(is_max.any(axis=1), np.argmax(masked, axis=1), np.argmax(sub, axis=1))
    else:
        k = np.argmax(sub, axis=1)
    amplitude = sub[np.arange(len(sub)), k]
    centre = inside[k]
    left = np.clip(centre - 1, 0, mag.shape[1] - 1)
    right = np.clip(centre + 1, 0, mag.shape[1] - 1)
    rows = np.arange(len(mag))
    y0, y1, y2 = (np.log(np.maximum(mag[rows, i], 1e-300)) for i in (left, centre, right))
    denom = y0 - 2 * y1 + y2
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(denom < 0, 0.5 * (y0 - y2) / denom, 0.0)
    shift = np.clip(shift, -0.5, 0.5)
    return amplitude, f[centre] + shift * (f[1] - f[0])


def causal_moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """Causal trailing mean of the last ``n`` values of (n_values,) ``x`` (fewer at the
    start), so that the value at k uses nothing after k."""
    if n < 1:
        raise ValueError(f"`n` (={n}) must be >= 1")
    x = np.asarray(x, dtype=np.float64)
    c = np.concatenate([[0.0], np.cumsum(x)])
    k = np.arange(1, len(x) + 1)
    lo = np.maximum(0, k - n)
    return (c[k] - c[lo]) / (k - lo)


class SpectrumTracker:
    """Frames of :func:`frame_spectra` computed as samples arrive.

    :meth:`push` takes a chunk of samples of any size and returns the frames it completed
    as :class:`FrameSpectra` (``t_s`` counted from the first sample ever pushed); memory
    stays one window.
    """

    def __init__(self, settings: FrameSettings):
        self.settings = settings
        self._buffer = np.zeros(0)
        self._consumed = 0          # samples dropped from the front of the buffer
        self._next_start = 0        # absolute index of the next frame's first sample

    def push(self, samples: np.ndarray) -> FrameSpectra:
        s = self.settings
        self._buffer = np.concatenate([self._buffer, np.asarray(samples, dtype=np.float64)])
        end = self._consumed + len(self._buffer)
        t, rows = [], []
        while self._next_start + s.window <= end:
            lo = self._next_start - self._consumed
            frame = self._buffer[lo:lo + s.window]
            frame = frame - frame.mean()
            rows.append(np.abs(np.fft.rfft(frame * s.taper, n=s.n_fft)))
            t.append((self._next_start + s.window - 1) / s.rate_hz)
            self._next_start += s.hop
        drop = max(0, self._next_start - self._consumed)
        drop = min(drop, len(self._buffer))
        self._buffer = self._buffer[drop:]
        self._consumed += drop
        mag = np.array(rows) if rows else np.zeros((0, s.n_fft // 2 + 1))
        return FrameSpectra(np.array(t, dtype=np.float64), s.f_hz, mag)
