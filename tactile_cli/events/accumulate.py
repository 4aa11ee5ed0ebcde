"""Event counts per fixed time bin, their moving average, and per-bin action labels.

Paper 000, sec. 4.2 (Fig. 10): the raw events of a trial are accumulated in 20 ms bins,
the net count (positive minus negative events) shows the four action regions (approach,
press, slip, release), and a moving average smooths it. This module is that accumulation:

- :func:`bin_events`: events in, :class:`EventCounts` out (vectorised, one ``np.bincount``
  per block of events);
- :func:`trial_counts`: the same for one trial of a tactile HDF5 file, reading its events
  in blocks of at most :data:`READ_BLOCK` events so memory stays bounded;
- :func:`moving_average`: centred moving average whose window shrinks symmetrically at
  the edges (no zero padding, so no bias towards zero at the trial's ends);
- :func:`counts_to_labels`: per-bin action labels from a trial's annotations.

Times: event timestamps ``t_us`` are integer microseconds of the camera clock; bin
centres ``t_s`` are seconds from the trial's time origin (the event timestamp
``start_us``). Bin ``k`` holds the events with
``start_us + k * bin_us <= t_us < start_us + (k + 1) * bin_us``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import h5py
import numpy as np

from ..errors import InputError
from ..fos.actions import ACTIONS, BIN_S
from ..store.reader import open_tactile

#: Channel order of :meth:`EventCounts.stack` (and of the ``event_counts`` HDF5 stream).
CHANNELS: tuple[str, ...] = ("positive", "negative", "net")
#: Events read from an HDF5 file per block (9 MiB of t and p columns).
READ_BLOCK = 1 << 20


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


def bin_us_of(bin_s: float) -> int:
    """``bin_s`` as a whole number of microseconds; ValueError when it is not one (> 0)."""
    if not (np.isfinite(bin_s) and bin_s > 0):
        raise ValueError(f"`bin_s` (={bin_s}) must be a positive number of seconds")
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


def unknown_trial(path: str | Path, trial: str, names: Sequence[str]) -> InputError:
    """The error for a trial name that is not in the file, listing (some of) its trials."""
    shown = ", ".join(names[:10]) + (f" and {len(names) - 10} more" if len(names) > 10 else "")
    return InputError(f"no trial {trial!r}; the file has {len(names)} trial(s): "
                      f"{shown or 'none'}", path=path)


def _open_trial_events(h5: h5py.File, path: str | Path, trial: str) -> h5py.Group:
    trials = h5["trials"]
    if trial not in trials:
        raise unknown_trial(path, trial, list(trials.keys()))
    group = trials[trial]
    if "events" not in group:
        raise InputError(
            "trial has no events (event counts need an event-camera recording)",
            path=path, where=f"/trials/{trial}",
        )
    events = group["events"]
    if events["t"].shape[0] == 0:
        raise InputError("trial has no events", path=path, where=f"/trials/{trial}/events")
    return events


def trial_origin_us(events: h5py.Group) -> int:
    """Event timestamp of a trial's time 0: attribute ``t_origin_us``, else
    ``ms_index_origin_us`` (the first event)."""
    if "t_origin_us" in events.attrs:
        return int(events.attrs["t_origin_us"])
    return int(events.attrs["ms_index_origin_us"])


def trial_counts(path: str | Path, trial: str, *, bin_s: float = BIN_S) -> EventCounts:
    """Event counts per bin of one trial of a tactile HDF5 file.

    The bins start at the trial's time origin (events attribute ``t_origin_us``, else
    ``ms_index_origin_us``, the first event, as in files written before that attribute)
    and cover ``[0, duration_s)`` of the trial, or up to the last event when that lies
    later; the last bin is partial when that span is not a whole number of bins. Events
    before the origin are not counted (``n_outside``). Events are read in blocks of
    :data:`READ_BLOCK`, the first located with ``ms_to_idx``, so memory is bounded by the
    block size and the counts. Raises :class:`InputError` for a
    file that is not a tactile file, an unknown trial or a trial without events.
    """
    path = Path(path)
    bin_us = bin_us_of(bin_s)
    with open_tactile(path) as h5:
        events = _open_trial_events(h5, path, trial)
        origin_us = trial_origin_us(events)
        index_origin_us = int(events.attrs["ms_index_origin_us"])
        t_ds, p_ds = events["t"], events["p"]
        n = t_ds.shape[0]
        t_last = int(t_ds[n - 1])
        duration_us = round(float(h5["trials"][trial].attrs["duration_s"]) * 1e6)
        end_us = max(origin_us + duration_us, t_last + 1)
        n_bins = -(-(end_us - origin_us) // bin_us)
        ms_to_idx = events["ms_to_idx"]  # one int64 per ms: read one entry, not all

        def first_index_at_or_after_ms(ms: int) -> int:
            if ms <= 0:
                return 0
            return int(ms_to_idx[ms]) if ms < ms_to_idx.shape[0] else n

        # events before the origin are skipped whole milliseconds at a time (the block
        # filter drops the rest); every event is counted or reported in n_outside
        lo = first_index_at_or_after_ms((origin_us - index_origin_us) // 1000)
        raw = np.zeros((n_bins, 2), dtype=np.int64)
        n_outside = lo
        for a in range(lo, n, READ_BLOCK):
            b = min(a + READ_BLOCK, n)
            n_outside += _accumulate(t_ds[a:b], p_ds[a:b], origin_us, end_us, bin_us, raw)
    return _counts(raw, bin_s, origin_us, n_outside)


def read_annotations(path: str | Path, trial: str) -> list[tuple[float, float, str]]:
    """``(start_s, end_s, label)`` of one trial's annotations (empty when it has none)."""
    path = Path(path)
    with open_tactile(path) as h5:
        if trial not in h5["trials"]:
            raise unknown_trial(path, trial, list(h5["trials"].keys()))
        group = h5["trials"][trial]
        if "annotations" not in group:
            return []
        ann = group["annotations"]
        starts = ann["start_s"][()]
        ends = ann["end_s"][()]
        labels = ann["label"].asstr()[()]
    return [(float(s), float(e), str(lab)) for s, e, lab in zip(starts, ends, labels,
                                                                strict=True)]


def moving_average(x: np.ndarray, window_bins: int) -> np.ndarray:
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
    """(n_bins,) int8 action index (into ``ACTIONS``) of each bin, by its centre ``t_s``.

    annotations: ``(start_s, end_s, label)`` intervals, a bin belonging to the interval
    with ``start_s <= t_s < end_s``. Labels are matched to ``ACTIONS`` ignoring case and
    surrounding spaces; annotations of other labels are not action regions and are
    skipped. Bins inside no action interval get -1. Where intervals overlap, the later
    annotation wins.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    labels = np.full(t_s.shape, -1, dtype=np.int8)
    for start_s, end_s, label in annotations:
        name = str(label).strip().lower()
        if name not in ACTIONS:
            continue
        labels[(t_s >= start_s) & (t_s < end_s)] = ACTIONS.index(name)
    return labels


__all__ = ["CHANNELS", "READ_BLOCK", "EventCounts", "bin_events", "bin_us_of",
           "counts_to_labels", "moving_average", "read_annotations", "trial_counts",
           "trial_origin_us", "unknown_trial"]
