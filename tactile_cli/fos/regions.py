"""Net event counts per bin of every trial of a tactile file, with its press and slip regions.

The input of ``tactile fit-fos`` (paper 000, sec. 4.2): the net count (positive minus
negative events) per 20 ms bin of each trial, and where its press and slip regions lie.

Counts come from the trial's events (binned by
:func:`tactile_cli.events.accumulate.trial_counts`, bins from the trial's time origin) or,
for a trial without events, from its ``signals/event_counts`` stream (written by
``tactile synth`` and ``tactile accumulate``: channel ``net``, or ``positive`` and
``negative``).

Regions come from the trial's ``/annotations`` (intervals labelled ``press`` and ``slip``,
case-insensitive) or are detected in the counts by
:func:`tactile_cli.events.segment.segment_actions`: ``regions="annotations"`` requires the
annotations, ``"detect"`` ignores them, ``"auto"`` uses them where a trial has both a press
and a slip interval and detects otherwise.

Times are seconds from the trial's time origin; a bin belongs to a region when its centre
lies in ``[start_s, end_s)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import InputError
from ..store.trials import TactileFile, Trial
from ..vocabulary import BIN_S

RegionsMode = Literal["annotations", "detect", "auto"]
REGION_MODES: tuple[str, ...] = ("annotations", "detect", "auto")
#: The count stream of a trial without events (contract of ``tactile synth`` / accumulate).
COUNTS_STREAM = "event_counts"
#: Relative tolerance when comparing a stream's bin width with the requested one.
_BIN_RTOL = 1e-6


@dataclass(frozen=True)
class TrialRegions:
    """Net counts of one trial and its press and slip regions.

    t_s: (n_bins,) float64 bin centres, seconds from the trial's time origin.
    net: (n_bins,) float64 net events per bin (positive minus negative).
    bin_s: bin width, seconds.
    press_s, slip_s: ``(start_s, end_s)`` of the regions, seconds from the time origin;
    NaN when the segmentation failed (``regions_note`` says why).
    regions_from: ``"annotations"`` or ``"detected"``.
    regions_note: the segmentation's message when it failed or is uncertain, else ``""``.
    counts_from: ``"events"`` or ``"signals/event_counts"``.
    labels: the trial's labels (``force_level``, ``force_grade``, ...).
    """

    trial: str
    t_s: np.ndarray
    net: np.ndarray
    bin_s: float
    press_s: tuple[float, float]
    slip_s: tuple[float, float]
    regions_from: str
    counts_from: str
    labels: dict[str, Any] = field(default_factory=dict)
    regions_note: str = ""

    @property
    def has_regions(self) -> bool:
        """Both regions have finite bounds (False when the segmentation failed)."""
        return bool(np.isfinite([*self.press_s, *self.slip_s]).all())

    def region(self, name: str) -> tuple[float, float]:
        """``(start_s, end_s)`` of ``"press"`` or ``"slip"``."""
        if name not in ("press", "slip"):
            raise ValueError(f"`name` (={name!r}) must be 'press' or 'slip'.")
        return self.press_s if name == "press" else self.slip_s

    def in_region(self, name: str) -> np.ndarray:
        """(n_bins,) bool: bins whose centre lies in the region."""
        start, end = self.region(name)
        return (self.t_s >= start) & (self.t_s < end)

    @property
    def force_level(self) -> int | None:
        """The ``force_level`` label as an int, or None when the trial has none."""
        return label_int(self.labels.get("force_level"))


def label_int(value: Any) -> int | None:
    """A label stored as int, float or text (``"7"``) as an int; None when absent or not one."""
    if value is None:
        return None
    if isinstance(value, bytes):
        value = value.decode()
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return int(number) if np.isfinite(number) and number == int(number) else None


def _stream_counts(trial: Trial, bin_s: float | None
                   ) -> tuple[np.ndarray, np.ndarray, float]:
    """Bin centres, net counts and bin width of a trial's ``signals/event_counts``."""
    where = f"{trial.where}/signals/{COUNTS_STREAM}"
    sensor = trial.signal_sensor(COUNTS_STREAM)
    if not sensor.channel_names:
        raise InputError(f"the stream's sensor {sensor.name!r} has no channel_names; cannot "
                         "find the net channel", path=trial.path, where=where)
    names = list(sensor.channel_names)
    if "net" in names:
        stream = trial.signal(COUNTS_STREAM, channels=["net"])
        net = stream.data[:, 0].astype(np.float64)
    elif "positive" in names and "negative" in names:
        stream = trial.signal(COUNTS_STREAM, channels=["positive", "negative"])
        data = stream.data.astype(np.float64)
        net = data[:, 0] - data[:, 1]
    else:
        raise InputError(f"channels {names} have neither 'net' nor 'positive' and 'negative'",
                         path=trial.path, where=where)
    t_s = stream.t_s
    stored = stream.attrs.get("bin_s", sensor.attrs.get("bin_s"))
    if stored is None:
        if len(t_s) < 2:
            raise InputError("the stream has no bin_s attribute and fewer than 2 bins",
                             path=trial.path, where=where)
        stored = float(np.median(np.diff(t_s)))
    stored = float(stored)
    if bin_s is not None and abs(stored - bin_s) > _BIN_RTOL * bin_s:
        raise InputError(f"the stream's bins are {stored * 1e3:g} ms, not the "
                         f"{bin_s * 1e3:g} ms asked for; pass `bin_s={stored:g}`",
                         path=trial.path, where=where)
    return t_s, net, stored


def _annotated_regions(trial: Trial) -> dict[str, tuple[float, float]] | None:
    """``{"press": (start, end), "slip": (start, end)}`` from the annotations, or None when
    the trial lacks either interval; an error when one is annotated more than once."""
    annotations = trial.annotations
    if not annotations:
        return None
    where = f"{trial.where}/annotations"
    labels = [a.label.strip().lower() for a in annotations]
    found: dict[str, tuple[float, float]] = {}
    for name in ("press", "slip"):
        idx = [i for i, lab in enumerate(labels) if lab == name]
        if len(idx) > 1:
            raise InputError(f"{len(idx)} intervals are labelled {name!r}; fit-fos fits one "
                             "press and one slip per trial (split the trial, or pass "
                             "`regions='detect'`)", path=trial.path, where=where)
        if idx:
            start, end = annotations[idx[0]].start_s, annotations[idx[0]].end_s
            if not (np.isfinite(start) and np.isfinite(end) and end > start):
                raise InputError(f"the {name!r} interval [{start}, {end}) s is empty or not "
                                 "finite", path=trial.path, where=where)
            found[name] = (start, end)
    return found if len(found) == 2 else None


def _detected_regions(net: np.ndarray, bin_s: float
                      ) -> tuple[dict[str, tuple[float, float]], str]:
    """Regions found by :func:`tactile_cli.events.segment.segment_actions` (NaN bounds when
    it failed) and its message."""
    from ..events.segment import segment_actions

    seg = segment_actions(net, bin_s=bin_s)
    note = "" if seg.status == "ok" else f"segmentation {seg.status}: {seg.message}"
    return ({"press": (float(seg.press_start_s), float(seg.slip_start_s)),
             "slip": (float(seg.slip_start_s), float(seg.release_start_s))}, note)


def read_trial_regions(
    source: str | Path | TactileFile,
    *,
    bin_s: float | None = None,
    regions: RegionsMode = "auto",
    trials: Sequence[str] | None = None,
) -> list[TrialRegions]:
    """Net counts and press/slip regions of the trials of a tactile HDF5 file.

    Parameters
    ----------
    source:
        A tactile HDF5 file (a path, opened here once, or an open
        :class:`~tactile_cli.store.trials.TactileFile`) whose trials have events or a
        ``signals/event_counts`` stream.
    bin_s:
        Bin width in seconds. None: 20 ms for events, the stream's own width for count
        streams; a count stream of another width is an error (streams are not re-binned).
    regions:
        ``"annotations"``, ``"detect"`` or ``"auto"`` (see the module doc).
    trials:
        Names of the trials to read; None: all, in file order.

    Raises :class:`InputError` for a trial with neither events nor counts, a trial without
    press/slip annotations under ``regions="annotations"``, or a file without trials.
    """
    if regions not in REGION_MODES:
        raise ValueError(f"`regions` (={regions!r}) must be one of {REGION_MODES}.")
    if bin_s is not None and not (np.isfinite(bin_s) and bin_s > 0):
        raise ValueError(f"`bin_s` (={bin_s}) must be a positive number of seconds.")
    if not isinstance(source, TactileFile):
        with TactileFile(source) as tf:
            return read_trial_regions(tf, bin_s=bin_s, regions=regions, trials=trials)
    tf, path = source, source.path
    names = tf.trial_names
    if trials is not None:
        missing = [t for t in trials if t not in tf.trial_names]
        if missing:
            raise InputError(f"no trial {missing[0]!r} in the file", path=path)
        names = list(trials)
    if not names:
        raise InputError("the file has no trials", path=path)
    # every trial is checked (annotations, counts present) before any events are counted
    plan = []
    for name in names:
        trial = tf.trial(name)
        ann = _annotated_regions(trial) if regions != "detect" else None
        if regions == "annotations" and ann is None:
            raise InputError("no 'press' and 'slip' annotations; add them at ingest "
                             "(`tactile ingest --annotations FILE`) or pass `regions='detect'`",
                             path=path, where=trial.where)
        if trial.has_events:
            plan.append((trial, ann, None))
        elif trial.has_signal(COUNTS_STREAM):
            plan.append((trial, ann, _stream_counts(trial, bin_s)))
        else:
            raise InputError("the trial has neither events nor a "
                             f"signals/{COUNTS_STREAM} stream; fit-fos needs event counts",
                             path=path, where=trial.where)

    out = []
    for trial, ann, stream in plan:
        if stream is None:
            from ..events.accumulate import trial_counts

            try:
                counts = trial_counts(trial, bin_s=BIN_S if bin_s is None else bin_s)
            except ValueError:  # a bin width that is not whole microseconds
                raise InputError(f"a bin width of {bin_s * 1e3:g} ms is not a whole number of "
                                 "microseconds; pass another `bin_s`", path=path) from None
            t_s, net, width = counts.t_s, counts.net.astype(np.float64), counts.bin_s
            counts_from = "events"
        else:
            (t_s, net, width), counts_from = stream, f"signals/{COUNTS_STREAM}"
        found, note = (ann, "") if ann is not None else _detected_regions(net, width)
        out.append(TrialRegions(
            trial=trial.name, t_s=t_s, net=net, bin_s=float(width), press_s=found["press"],
            slip_s=found["slip"], regions_from="annotations" if ann is not None else "detected",
            counts_from=counts_from, labels=trial.labels, regions_note=note))
    return out


__all__ = ["COUNTS_STREAM", "REGION_MODES", "RegionsMode", "TrialRegions", "label_int",
           "read_trial_regions"]
