"""Time stamps as real loggers write them: repeated and out-of-order stamps, stated not refused.

A logger that stamps in whole milliseconds, or holds a sample while the bus is busy, writes
the same stamp twice; one that buffers may write a stamp earlier than the one before. A
sample is *late* when its stamp does not advance the clock: it is equal to (**repeated**) or
earlier than (**out of order**) the latest stamp before it. Every late sample joins the
*group* of the last sample that advanced the clock, so a recording is a run of groups, each
opened by one stamp later than every stamp before it.

A stream's policy (:data:`STAMP_POLICIES`; the mapping's ``time.stamps``) says what an
ingest does with late samples:

- ``refuse`` (the default): the ingest stops with one line naming the file and line;
- ``drop_repeats``: each group keeps its first sample (the late ones are dropped);
- ``keep_last``: each group keeps its last sample (the newest value the logger wrote before
  the clock moved on), at the group's stamp;
- ``spread``: every sample is kept, in file order; the k samples of a group are spread
  evenly from the group's stamp towards the next group's stamp (``T + j/k * (T_next - T)``,
  j = 0..k-1); the last group uses the interval before it (or the nominal rate).

Every policy gives strictly increasing times. :func:`stamp_stats` counts what a recording
holds (for ``tactile info``), :func:`settle_stamps` applies a policy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

#: What an ingest does with repeated and out-of-order stamps (see the module docstring).
StampPolicy = Literal["refuse", "drop_repeats", "keep_last", "spread"]
STAMP_POLICIES: tuple[str, ...] = ("refuse", "drop_repeats", "keep_last", "spread")


@dataclass(frozen=True)
class StampStats:
    """The timing of one run of stamps (seconds).

    n: stamps; n_repeated, n_out_of_order: late samples (see the module docstring);
    first_repeated, first_out_of_order: index of the first of each (None when there is
    none); rate_hz: 1 / the median positive interval between consecutive stamps; jitter_s:
    standard deviation of the intervals between consecutive stamps (None with fewer than
    two stamps, and rate_hz None without a positive interval).
    """

    n: int
    n_repeated: int
    n_out_of_order: int
    first_repeated: int | None
    first_out_of_order: int | None
    rate_hz: float | None
    jitter_s: float | None

    @property
    def n_late(self) -> int:
        return self.n_repeated + self.n_out_of_order


def _late(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n,) bool masks of repeated and out-of-order samples of (n,) stamps ``t``."""
    repeated = np.zeros(len(t), dtype=bool)
    back = np.zeros(len(t), dtype=bool)
    if len(t) > 1:
        latest = np.maximum.accumulate(t)[:-1]  # the latest stamp before each sample
        repeated[1:] = t[1:] == latest
        back[1:] = t[1:] < latest
    return repeated, back


def stamp_stats(t: np.ndarray) -> StampStats:
    """Count the late samples of (n,) stamps ``t`` and measure their rate and jitter."""
    t = np.asarray(t, dtype=np.float64)
    repeated, back = _late(t)
    steps = np.diff(t)
    positive = steps[steps > 0]
    rate = float(1.0 / np.median(positive)) if len(positive) else None
    jitter = interval_jitter_s(steps)
    rep, out = np.flatnonzero(repeated), np.flatnonzero(back)
    return StampStats(n=len(t), n_repeated=len(rep), n_out_of_order=len(out),
                      first_repeated=int(rep[0]) if len(rep) else None,
                      first_out_of_order=int(out[0]) if len(out) else None,
                      rate_hz=rate, jitter_s=jitter)


def interval_jitter_s(steps: np.ndarray) -> float | None:
    """Standard deviation of (n,) intervals in seconds, rounded to the nanosecond (so that
    evenly spaced float times give 0, not 1e-17); None without intervals."""
    return float(np.round(np.std(steps), 9)) if len(steps) else None


@dataclass(frozen=True)
class SettledStamps:
    """Stamps after a policy: keep: (m,) indices of the samples kept, in order (None when
    every sample is kept); t: (m,) strictly increasing stamps of the samples kept;
    n_repeated, n_out_of_order: the late samples met."""

    keep: np.ndarray | None
    t: np.ndarray
    n_repeated: int
    n_out_of_order: int

    @property
    def n_dropped(self) -> int:
        return self.n_repeated + self.n_out_of_order if self.keep is not None else 0


class StampError(ValueError):
    """A policy cannot be applied (``spread`` with one group and no interval to spread in)."""


def settle_stamps(t: np.ndarray, policy: StampPolicy, *,
                  last_interval: float | None = None) -> SettledStamps:
    """Apply ``policy`` to (n,) stamps ``t`` (see the module docstring).

    last_interval: the interval the last group of ``spread`` spreads over when the stamps
    hold a single group (one stamp, repeated), e.g. 1 / the nominal rate; otherwise the
    interval before the last group is used. ``refuse`` returns the stamps unchanged when no
    sample is late and raises :class:`StampError` otherwise (callers that can name the
    file and line check :func:`stamp_stats` first).
    """
    t = np.asarray(t, dtype=np.float64)
    repeated, back = _late(t)
    late = repeated | back
    n_rep, n_back = int(repeated.sum()), int(back.sum())
    if not late.any():
        return SettledStamps(keep=None, t=t, n_repeated=0, n_out_of_order=0)
    if policy == "refuse":
        raise StampError(f"{n_rep} repeated and {n_back} out-of-order stamps")
    starts = np.flatnonzero(~late)  # the sample opening each group
    stamps = t[starts]
    if policy == "drop_repeats":
        return SettledStamps(keep=starts, t=stamps, n_repeated=n_rep, n_out_of_order=n_back)
    if policy == "keep_last":
        ends = np.append(starts[1:] - 1, len(t) - 1)
        return SettledStamps(keep=ends, t=stamps, n_repeated=n_rep, n_out_of_order=n_back)
    if policy != "spread":
        raise ValueError(f"unknown stamp policy {policy!r}; use one of {STAMP_POLICIES}")
    if len(stamps) >= 2:
        last = stamps[-1] - stamps[-2]
    elif last_interval is not None and last_interval > 0:
        last = float(last_interval)
    else:
        raise StampError("every stamp is the same, so there is no interval to spread the "
                         "samples over")
    following = np.append(stamps[1:], stamps[-1] + last)
    group = np.cumsum(~late) - 1  # the group of every sample
    size = np.diff(np.append(starts, len(t)))
    position = np.arange(len(t)) - starts[group]
    spread = stamps[group] + position / size[group] * (following - stamps)[group]
    return SettledStamps(keep=None, t=spread, n_repeated=n_rep, n_out_of_order=n_back)


__all__ = ["STAMP_POLICIES", "SettledStamps", "StampError", "StampPolicy", "StampStats",
           "interval_jitter_s", "settle_stamps", "stamp_stats"]
