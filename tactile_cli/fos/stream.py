"""Step responses of a sampled stream over annotated regions (``tactile fit-fos FILE
--stream NAME``).

For every trial of a tactile HDF5 file and every annotation (or every annotation with a
given label), the stream's samples whose time lies in ``[start, end)`` of the annotation
are one step response, ``t = sample time - start``. The value before the step (the
baseline) is subtracted so that the response starts at zero as the step model
``alpha (1 - exp(-t/tau))`` assumes: the mean of the samples in the window of the same
length just before the region (within the trial), or, when the region starts at the first
sample, the first sample of the region. ``alpha`` is then in the stream's units.

Channels are chosen by a glob (``fnmatch``, case-sensitive, several globs separated by
commas) and fitted one by one (``reduce="none"``) or as their mean (``reduce="mean"``).
Everything is read and checked before anything is fitted; all curves of the file are
fitted in one batched call (:func:`tactile_cli.fos.protocol.fit_curves`).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..store.trials import TactileFile

REDUCE_MODES: tuple[str, ...] = ("none", "mean")


@dataclass(frozen=True)
class StreamCurve:
    """One step response: ``t_s`` seconds from the region start, ``x`` the response with the
    baseline subtracted, in ``units``; ``start_s``/``end_s`` the region in trial seconds."""

    trial: str
    channel: str
    region: str
    t_s: np.ndarray
    x: np.ndarray
    units: str
    start_s: float
    end_s: float
    baseline: float

    @property
    def name(self) -> str:
        return f"{self.trial}/{self.channel}/{self.region}"


def match_channels(names: Sequence[str], pattern: str | None) -> list[str]:
    """The channels of ``names`` matching any of the comma-separated globs of ``pattern``
    (all when None), in the stream's order; an empty list when none matches."""
    if pattern is None:
        return list(names)
    globs = [g.strip() for g in pattern.split(",") if g.strip()]
    return [n for n in names if any(fnmatch.fnmatchcase(n, g) for g in globs)]


def _baseline(t: np.ndarray, x: np.ndarray, start: float, end: float) -> float:
    before = (t < start) & (t >= start - (end - start))
    if before.any():
        return float(np.mean(x[before]))
    inside = (t >= start) & (t < end)
    return float(x[inside][0])


def read_stream_curves(
    source: str | Path | TactileFile,
    stream: str,
    *,
    channels: str | None = None,
    reduce: str = "none",
    region_label: str | None = None,
    min_points: int = 4,
) -> list[StreamCurve]:
    """The step responses of ``stream`` over the annotated regions of every trial (see the
    module doc). ``region_label``: only annotations with this label (case and surrounding
    spaces ignored); None: every annotation.

    Raises :class:`InputError` for a file without trials, a trial without the stream, a
    glob that matches no channel, channels of several units averaged, a trial without
    (matching) annotations, or a region with fewer than ``min_points`` samples.
    """
    if reduce not in REDUCE_MODES:
        raise ValueError(f"`reduce` (={reduce!r}) must be one of {REDUCE_MODES}.")
    if not isinstance(source, TactileFile):
        with TactileFile(source) as tf:
            return read_stream_curves(tf, stream, channels=channels, reduce=reduce,
                                      region_label=region_label, min_points=min_points)
    tf, path = source, source.path
    if not tf.trial_names:
        raise InputError("the file has no trials", path=path)
    want = None if region_label is None else region_label.strip().lower()
    out: list[StreamCurve] = []
    for name in tf.trial_names:
        trial = tf.trial(name)
        if not trial.has_signal(stream):
            raise InputError(f"no stream {stream!r} (streams: "
                             f"{', '.join(trial.signal_names) or 'none'})",
                             path=path, where=trial.where)
        names = trial.signal_sensor(stream).channel_names
        chosen = match_channels(names, channels)
        if not chosen:
            raise InputError(f"`channels` (={channels!r}) matches no channel of stream "
                             f"{stream!r} (channels: {', '.join(names) or 'none'})",
                             path=path, where=trial.where)
        annotations = [a for a in trial.annotations
                       if want is None or a.label.strip().lower() == want]
        if not annotations:
            what = "annotations" if want is None else f"annotations labelled {region_label!r}"
            raise InputError(f"no {what} to fit (labels: "
                             f"{', '.join(sorted({a.label for a in trial.annotations})) or 'none'}"
                             "); add them at ingest (`tactile ingest --annotations FILE`)",
                             path=path, where=trial.where)
        sig = trial.signal(stream, channels=chosen)
        data = np.asarray(sig.data, dtype=np.float64)
        units = list(sig.channel_units)
        labels = list(sig.channel_names)
        if reduce == "mean":
            if len(set(units)) > 1:
                raise InputError(f"`reduce='mean'` averages channels of different units "
                                 f"({', '.join(sorted(set(units)))}); choose channels of one "
                                 "unit with `channels`", path=path, where=sig.where)
            data = data.mean(axis=1, keepdims=True)
            labels = ["mean" if channels is None else f"mean({channels})"]
            units = units[:1]
        seen: dict[str, int] = {}
        for ann in annotations:
            seen[ann.label] = seen.get(ann.label, 0) + 1
            region = ann.label if seen[ann.label] == 1 else f"{ann.label}#{seen[ann.label]}"
            inside = (sig.t_s >= ann.start_s) & (sig.t_s < ann.end_s)
            if inside.sum() < min_points:
                raise InputError(f"the {region!r} interval [{ann.start_s:g}, {ann.end_s:g}) s "
                                 f"holds {int(inside.sum())} samples of stream {stream!r}; at "
                                 f"least {min_points} are needed", path=path,
                                 where=trial.where)
            t = sig.t_s[inside] - ann.start_s
            for c, label in enumerate(labels):
                base = _baseline(sig.t_s, data[:, c], ann.start_s, ann.end_s)
                out.append(StreamCurve(name, label, region, t, data[inside, c] - base,
                                       units[c] or "units", ann.start_s, ann.end_s, base))
    return out


__all__ = ["REDUCE_MODES", "StreamCurve", "match_channels", "read_stream_curves"]
