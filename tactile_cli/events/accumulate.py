"""Event counts per fixed time bin, their moving average, and per-bin action labels.

Paper 000, sec. 4.2 (Fig. 10): the raw events of a trial are accumulated in 20 ms bins,
the net count (positive minus negative events) shows the four action regions (approach,
press, slip, release), and a moving average smooths it. This module is that accumulation:

- :func:`bin_events`: events in, :class:`EventCounts` out (vectorised, one ``np.bincount``
  per block of events);
- :func:`trial_counts`: the same for one :class:`~tactile_cli.store.trials.Trial` of an
  open tactile HDF5 file, reading its events in blocks of at most :data:`READ_BLOCK`
  events so memory stays bounded;
- :func:`centred_moving_average`: the centred moving average, whose window shrinks
  symmetrically at the edges (no zero padding, so no bias towards zero at the trial's ends;
  ``spectral.causal_moving_average`` is the trailing one of live streams);
- :func:`counts_to_labels`: per-bin action labels from a trial's annotations
  (:attr:`Trial.annotations <tactile_cli.store.trials.Trial.annotations>`).

Times: event timestamps ``t_us`` are integer microseconds of the camera clock; bin
centres ``t_s`` are seconds from the trial's time origin (the event timestamp
``start_us``). Bin ``k`` holds the events with
``start_us + k * bin_us <= t_us < start_us + (k + 1) * bin_us``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..errors import InputError
from ..store.trials import READ_BLOCK
from ..vocabulary import BIN_S, action_index

if TYPE_CHECKING:
    from ..store.trials import Trial

#: Channel order of :meth:`EventCounts.stack` (and of the ``event_counts`` HDF5 stream).
CHANNELS: tuple[str, ...] = ("positive", "negative", "net")


@dataclass(frozen=True)
class EventCounts:
    """Events per bin of one trial.

    t_s: (n_bins,) float64 bin centres, seconds from the trial's time origin.
    positive, negative: (n_bins,) int64 events of polarity +1 and -1 per bin.
    net: (n_bins,) int64 ``positive - negative`` per bin.
    bin_s: bin width in seconds.
    start_us: event timestamp (us) of the trial's time origin, the left edge of bin 0.
    n_outside: events that fell outside the bins (before ``start_us`` or at/after the end).
    """

    CHANNELS: ClassVar[tuple[str, ...]] = CHANNELS

    t_s: np.ndarray
    positive: np.ndarray
    negative: np.ndarray
    net: np.ndarray
    bin_s: float
    start_us: int = 0
    n_outside: int = 0

    @property
    def n_bins(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def n_events(self) -> int:
        """Events counted in the bins."""
        return int(self.positive.sum() + self.negative.sum())

    @property
    def end_s(self) -> float:
        """Right edge of the last bin, seconds from the trial's time origin."""
        return self.n_bins * self.bin_s

    def stack(self) -> np.ndarray:
        """(n_bins, 3) float32 counts, columns :data:`CHANNELS` (positive, negative, net)."""
        return np.stack([self.positive, self.negative, self.net], axis=1).astype(np.float32)


#: The longest bin (s): one day; a longer one is a unit slip, and beyond about 9e12 s the
#: microseconds no longer fit the int64 event times.
MAX_BIN_S = 86_400.0


def bin_us_of(bin_s: float) -> int:
    """``bin_s`` as a whole number of microseconds; ValueError when it is not one (> 0, at
    most :data:`MAX_BIN_S`)."""
    if not (np.isfinite(bin_s) and 0 < bin_s <= MAX_BIN_S):
        raise ValueError(f"`bin_s` (={bin_s}) must be positive and at most a day "
                         f"({MAX_BIN_S:g} s)")
    bin_us = round(bin_s * 1e6)
    if bin_us < 1 or abs(bin_us - bin_s * 1e6) > 1e-6 * bin_s * 1e6:
        raise ValueError(f"`bin_s` (={bin_s}) must be a whole number of microseconds")
    return int(bin_us)


def _accumulate(
    t_us: np.ndarray, p: np.ndarray, start_us: int, end_us: int, bin_us: int, out: np.ndarray
) -> int:
    """Add the events of one block into ``out`` ((n_bins, 2) int64: negative, positive);
    returns how many fell outside ``[start_us, end_us)``."""
    n_bins = out.shape[0]
    inside = (t_us >= start_us) & (t_us < end_us)
    k = (t_us[inside] - start_us) // bin_us
    # one bincount over (bin, polarity) pairs: index 2k for -1, 2k + 1 for +1
    code = 2 * k + (p[inside] > 0)
    out += np.bincount(code, minlength=2 * n_bins).reshape(n_bins, 2)
    return int(t_us.shape[0] - k.shape[0])


def _check_polarity(p: np.ndarray) -> None:
    if p.size and not ((p == 1) | (p == -1)).all():
        bad = p[(p != 1) & (p != -1)][0]
        raise ValueError(f"`p` holds {bad}; polarities must be -1 or +1")


def _counts(raw: np.ndarray, bin_s: float, start_us: int, n_outside: int) -> EventCounts:
    negative = np.ascontiguousarray(raw[:, 0])
    positive = np.ascontiguousarray(raw[:, 1])
    t_s = (np.arange(raw.shape[0], dtype=np.float64) + 0.5) * bin_s
    return EventCounts(t_s, positive, negative, positive - negative, float(bin_s),
                       int(start_us), int(n_outside))


def bin_events(
    t_us: np.ndarray,
    p: np.ndarray,
    *,
    bin_s: float = BIN_S,
    start_us: int = 0,
    end_us: int | None = None,
) -> EventCounts:
    """Count events per polarity in bins of ``bin_s`` seconds from ``start_us``.

    t_us: (n,) integer timestamps in microseconds (any order). p: (n,) polarity -1/+1.
    ``start_us`` is the trial's time origin (left edge of bin 0). With ``end_us`` the bins
    cover ``[start_us, end_us)``: ``ceil((end_us - start_us) / bin_us)`` bins, the last one
    partial when the span is not a whole number of bins (it then counts only events before
    ``end_us``). Without it the bins run up to and including the last event's bin (no bins
    when no event lies at or after ``start_us``). Events outside are counted in
    ``n_outside``. ``bin_s`` must be a whole number of microseconds.
    """
    t_us = np.asarray(t_us)
    p = np.asarray(p)
    if t_us.ndim != 1 or p.shape != t_us.shape:
        raise ValueError(f"`t_us` and `p` must be 1-D of equal length, got shapes "
                         f"{t_us.shape} and {p.shape}")
    if t_us.dtype.kind not in "iu":
        raise ValueError(f"`t_us` must hold integer microseconds, got dtype {t_us.dtype}")
    _check_polarity(p)
    bin_us = bin_us_of(bin_s)
    t_us = t_us.astype(np.int64, copy=False)
    start_us = int(start_us)
    if end_us is None:
        last = int(t_us.max()) if t_us.size else start_us - 1
        n_bins = (last - start_us) // bin_us + 1 if last >= start_us else 0
        end = start_us + n_bins * bin_us
    else:
        end = int(end_us)
        if end <= start_us:
            raise ValueError(f"`end_us` (={end_us}) must be later than `start_us` (={start_us})")
        n_bins = -(-(end - start_us) // bin_us)
    raw = np.zeros((n_bins, 2), dtype=np.int64)
    n_outside = _accumulate(t_us, p, start_us, end, bin_us, raw)
    return _counts(raw, bin_s, start_us, n_outside)


def trial_counts(trial: Trial, *, bin_s: float = BIN_S) -> EventCounts:
    """Event counts per bin of one trial of an open tactile HDF5 file.

    The bins start at the trial's time origin (:attr:`TrialEvents.origin_us
    <tactile_cli.store.trials.TrialEvents.origin_us>`: events attribute ``t_origin_us``,
    else ``ms_index_origin_us``, the first event, as in files written before that
    attribute) and cover ``[0, duration_s)`` of the trial, or up to the last event when
    that lies later; the last bin is partial when that span is not a whole number of bins.
    Events before the origin are not counted (``n_outside``). Events are read in blocks of
    :data:`READ_BLOCK`, the first located with ``ms_to_idx``, so memory is bounded by the
    block size and the counts. Raises :class:`InputError` for a trial without events.
    """
    bin_us = bin_us_of(bin_s)
    if not trial.has_events:
        raise InputError("trial has no events (event counts need an event-camera recording)",
                         path=trial.path, where=trial.where)
    events = trial.events
    if events.n_events == 0:
        raise InputError("trial has no events", path=trial.path, where=events.where)
    origin_us = events.origin_us
    duration_us = round(trial.duration_s * 1e6)
    end_us = max(origin_us + duration_us, events.t_last_us + 1)
    n_bins = -(-(end_us - origin_us) // bin_us)
    # events before the origin are skipped without being read; every event is counted or
    # reported in n_outside
    lo = events.index_at_or_after(origin_us)
    raw = np.zeros((n_bins, 2), dtype=np.int64)
    n_outside = lo
    for t_us, p in events.blocks(lo, READ_BLOCK):
        n_outside += _accumulate(t_us, p, origin_us, end_us, bin_us, raw)
    return _counts(raw, bin_s, origin_us, n_outside)


def centred_moving_average(x: np.ndarray, window_bins: int) -> np.ndarray:
    """Centred moving average along axis 0, same shape as ``x``, float64.

    x: (n,) or (n, c). ``window_bins`` must be odd (a centred window); sample ``i`` is the
    mean of ``x[i - h_i : i + h_i + 1]`` with ``h_i = min((window_bins - 1) // 2, i,
    n - 1 - i)``: the window shrinks symmetrically at the edges, so it stays centred and
    is never padded with zeros (the first and last samples are their own average).
    """
    if isinstance(window_bins, bool) or int(window_bins) != window_bins or window_bins < 1 \
            or window_bins % 2 == 0:
        raise ValueError(f"`window_bins` (={window_bins}) must be an odd whole number >= 1 "
                         "(an even window cannot be centred)")
    x = np.asarray(x, dtype=np.float64)
    if x.ndim not in (1, 2):
        raise ValueError(f"`x` must be (n,) or (n, c), got shape {x.shape}")
    n = x.shape[0]
    if n == 0 or window_bins == 1:
        return x.copy()
    i = np.arange(n)
    h = np.minimum((int(window_bins) - 1) // 2, np.minimum(i, n - 1 - i))
    csum = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    width = (2 * h + 1).astype(np.float64)
    if x.ndim == 2:
        width = width[:, None]
    return (csum[i + h + 1] - csum[i - h]) / width


def counts_to_labels(
    t_s: np.ndarray, annotations: Sequence[tuple[float, float, str]]
) -> np.ndarray:
    """(n_bins,) int8 action index (into :data:`~tactile_cli.vocabulary.ACTIONS`) of each
    bin, by its centre ``t_s``.

    annotations: ``(start_s, end_s, label)`` intervals, a bin belonging to the interval
    with ``start_s <= t_s < end_s``. Labels are matched to the actions ignoring case and
    surrounding spaces (:func:`~tactile_cli.vocabulary.action_index`); annotations of other
    labels are not action regions and are skipped. Bins inside no action interval get -1.
    Where intervals overlap, the later annotation wins.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    labels = np.full(t_s.shape, -1, dtype=np.int8)
    for start_s, end_s, label in annotations:
        index = action_index(label)
        if index is None:
            continue
        labels[(t_s >= start_s) & (t_s < end_s)] = index
    return labels


__all__ = ["CHANNELS", "MAX_BIN_S", "READ_BLOCK", "EventCounts", "bin_events", "bin_us_of",
           "counts_to_labels", "centred_moving_average", "trial_counts"]
