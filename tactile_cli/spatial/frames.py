"""Event frames: events accumulated over time windows onto the sensor grid (paper 000, sec. 4.3).

"Spatially visual-mapped camera frames are constructed by mapping event coordinates onto a
2D grid corresponding to the sensor's camera resolution ... The frames are segmented by
dividing the event stream into frames based on an accumulation time delta ... noise
suppression (salt-and-pepper noise) was achieved using a median filter" (Fig. 13).

- :func:`accumulate_frames`: events in, per-polarity count frames out, one ``np.bincount``
  over (frame, polarity, pixel) codes for a whole batch of windows;
- :func:`median_filter_frames`: ``scipy.ndimage.median_filter`` over each frame's plane;
- :func:`iter_trial_frames`: the frames of one trial of a tactile HDF5 file (a
  :class:`~tactile_cli.store.trials.Trial`), read window batch by window batch so memory
  stays bounded.

Frames are ``(n_frames, height_px, width_px)``: row ``y``, column ``x``, as the events'
pixel coordinates (``0 <= x < width_px``, ``0 <= y < height_px``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..store.trials import Trial
from .trial_events import spatial_events

#: Frames accumulated per bincount when a trial is read (3 x 8 x 640 x 480 int64 = 59 MB).
FRAME_BATCH = 8


@dataclass(frozen=True)
class EventFrames:
    """Event counts per pixel and time window.

    t_s: (n_frames,) float64 window starts, seconds from the trial's time origin.
    positive, negative: (n_frames, height_px, width_px) int32 events of polarity +1 / -1
    per pixel (after the median filter when ``median > 1``).
    window_s: window length in seconds; median: median-filter size in px (1 = none).
    """

    t_s: np.ndarray
    positive: np.ndarray
    negative: np.ndarray
    window_s: float
    median: int = 1

    @property
    def net(self) -> np.ndarray:
        """(n_frames, height_px, width_px) int32 ``positive - negative``."""
        return self.positive - self.negative

    @property
    def n_frames(self) -> int:
        return int(self.t_s.shape[0])


def _check_median(median: int) -> int:
    if isinstance(median, bool) or int(median) != median or median < 1 or median % 2 == 0:
        raise ValueError(f"`median` (={median}) must be an odd whole number of px >= 1 "
                         "(1 = no filter)")
    return int(median)


def accumulate_frames(
    x: np.ndarray,
    y: np.ndarray,
    t_us: np.ndarray,
    p: np.ndarray,
    *,
    width_px: int,
    height_px: int,
    start_us: int,
    window_us: int,
    n_frames: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-polarity count frames of ``n_frames`` consecutive windows.

    x, y: (n,) pixel coordinates; t_us: (n,) integer microseconds; p: (n,) -1/+1.
    Frame ``k`` counts the events with ``start_us + k*window_us <= t_us < start_us +
    (k+1)*window_us``; events outside the windows or the grid are ignored.
    Returns ``(positive, negative)``, each (n_frames, height_px, width_px) int32.
    """
    x = np.asarray(x, dtype=np.int64)
    y = np.asarray(y, dtype=np.int64)
    t_us = np.asarray(t_us, dtype=np.int64)
    p = np.asarray(p)
    if not (x.shape == y.shape == t_us.shape == p.shape) or x.ndim != 1:
        raise ValueError(f"`x`, `y`, `t_us`, `p` must be 1-D of equal length, got shapes "
                         f"{x.shape}, {y.shape}, {t_us.shape}, {p.shape}")
    if window_us <= 0 or n_frames < 0:
        raise ValueError(f"`window_us` (={window_us}) must be > 0 and `n_frames` "
                         f"(={n_frames}) >= 0")
    n_px = width_px * height_px
    k = (t_us - start_us) // window_us
    keep = (k >= 0) & (k < n_frames) & (x >= 0) & (x < width_px) & (y >= 0) & (y < height_px)
    # one code per (frame, polarity, pixel): polarity 0 = negative, 1 = positive
    code = (2 * k[keep] + (p[keep] > 0)) * n_px + y[keep] * width_px + x[keep]
    counts = np.bincount(code, minlength=2 * n_frames * n_px)
    counts = counts.reshape(n_frames, 2, height_px, width_px).astype(np.int32)
    return counts[:, 1], counts[:, 0]


def median_filter_frames(frames: np.ndarray, size: int) -> np.ndarray:
    """Median filter of ``size`` x ``size`` px over each frame of (n_frames, H, W) (or (H, W))
    counts; frames are filtered independently (no filtering across time). Edges are
    reflected (scipy's default), so a border pixel is not darkened by padding zeros."""
    size = _check_median(size)
    if size == 1:
        return frames
    footprint = (size, size) if frames.ndim == 2 else (1, size, size)
    return ndimage.median_filter(frames, size=footprint)


def iter_trial_frames(
    trial: Trial,
    *,
    window_s: float,
    start_s: float = 0.0,
    end_s: float | None = None,
    median: int = 1,
    batch: int = FRAME_BATCH,
) -> Iterator[EventFrames]:
    """The event frames of one trial, ``batch`` windows at a time.

    Windows of ``window_s`` seconds tile ``[start_s, end_s)`` (trial seconds; ``end_s``
    defaults to the trial's end; the last window may be partial). Each batch's events are
    read through the millisecond index, so memory is bounded by ``batch`` frames.
    """
    median = _check_median(median)
    window_us = round(window_s * 1e6)
    if window_us < 1:
        raise ValueError(f"`window_s` (={window_s}) must be at least 1 us")
    te = spatial_events(trial)
    width_px, height_px = te.sensor.width_px, te.sensor.height_px
    stop_s = te.end_s if end_s is None else end_s
    start_us = te.to_us(start_s)
    stop_us = te.to_us(stop_s)
    n_total = max(0, -(-(stop_us - start_us) // window_us))
    for first in range(0, n_total, batch):
        n = min(batch, n_total - first)
        t0_us = start_us + first * window_us
        t1_us = min(t0_us + n * window_us, stop_us)
        ev = te.window_us(t0_us, t1_us)
        pos, neg = accumulate_frames(
            ev.x, ev.y, ev.t_us, ev.p, width_px=width_px, height_px=height_px,
            start_us=t0_us, window_us=window_us, n_frames=n,
        )
        t_s = start_s + (first + np.arange(n)) * window_us * 1e-6
        yield EventFrames(t_s, median_filter_frames(pos, median),
                          median_filter_frames(neg, median), window_us * 1e-6, median)
