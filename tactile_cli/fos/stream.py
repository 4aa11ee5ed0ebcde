"""Step responses of a sampled stream over annotated regions (``tactile fit-fos FILE
--stream NAME``).

For every trial of a tactile HDF5 file and every annotation (or every annotation with a
given label), the stream's samples whose time lies in ``[start, end)`` of the annotation
are one step response, ``t = sample time - start``. The value before the step (the
baseline) is subtracted so that the response starts at zero as the step model
``alpha (1 - exp(-t/tau))`` assumes: the mean of the samples in the window of the same
length just before the region (within the trial), or, when the region starts at the first
sample, the first sample of the region. ``alpha`` is then in the stream's units.

Regions come from the trials' annotations (``regions="annotations"``), or are found in the
signal (``"detect"``: :func:`tactile_cli.fos.step_detect.detect_steps` on each curve, that
is on each channel, or on their mean with ``reduce="mean"``; regions labelled ``rise`` and
``fall``; for the step model each start is then moved to the sample, of the found one
and its neighbours, that a first-order step fits best:
:func:`~tactile_cli.fos.step_detect.best_step_start`), or from annotations where a trial
has matching ones and found otherwise (``"auto"``). Curves in which no step is found are
listed in :attr:`StreamCurves.no_step`, not fitted. With ``model="pulse"`` and found
regions, a rise and the fall after it are one region labelled ``pulse`` (the press and its
release; the pulse length T is then fitted).

Channels are chosen by a glob (``fnmatch``, case-sensitive, several globs separated by
commas) and fitted one by one (``reduce="none"``) or as their mean (``reduce="mean"``).
Everything is read and checked before anything is fitted; all curves of the file are
fitted in one batched call (:func:`tactile_cli.fos.protocol.fit_curves`).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..store.trials import TactileFile
from .step_detect import MIN_SNR, best_step_start, find_steps, level_before

REDUCE_MODES: tuple[str, ...] = ("none", "mean")
STREAM_REGION_MODES: tuple[str, ...] = ("annotations", "detect", "auto")
#: Curves (trial x channel x region; a channel searched for steps counts once) that one
#: call reads at most by default: 4,096 take about 20 s on one core, the 76,800 pixels of a
#: 320 x 240 height map about 7 minutes.
MAX_CURVES = 4096
#: CPU seconds per curve on one core, for the estimate in the refusal (measured with 2,000
#: channels of 30 samples, order test included: ~2.5 ms to search a channel for steps,
#: ~3 ms to fit a curve and test the second order).
SEARCH_S_PER_CURVE = 2.5e-3
FIT_S_PER_CURVE = 3e-3


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


@dataclass(frozen=True)
class StreamCurves:
    """The curves to fit, and the ``trial/channel`` names of curves with no step found
    (``regions="detect"`` or ``"auto"``). ``not_fitted``: ``trial/channel`` (or
    ``trial/channel/region`` for one step left out) -> why nothing (or that step) is fitted:
    a flat channel, no change above the threshold, a step cut by the end of the
    recording; every curve searched is either fitted or named here."""

    curves: list[StreamCurve]
    no_step: list[str]
    not_fitted: dict[str, str] = field(default_factory=dict)


def match_channels(names: Sequence[str], pattern: str | None) -> list[str]:
    """The channels of ``names`` matching any of the comma-separated globs of ``pattern``
    (all when None), in the stream's order; an empty list when none matches."""
    if pattern is None:
        return list(names)
    globs = [g.strip() for g in pattern.split(",") if g.strip()]
    return [n for n in names if any(fnmatch.fnmatchcase(n, g) for g in globs)]


def _numbered(spans: list[tuple[float, float, str]]) -> list[tuple[float, float, str]]:
    """Regions named by their label, repeated labels numbered: press, press#2, ..."""
    seen: dict[str, int] = {}
    out = []
    for start, end, label in spans:
        seen[label] = seen.get(label, 0) + 1
        out.append((start, end, label if seen[label] == 1 else f"{label}#{seen[label]}"))
    return out


def _found_regions(t_s: np.ndarray, x: np.ndarray, *, model: str, want: str | None,
                   min_snr: float, min_points: int
                   ) -> tuple[list[tuple[float, float, str]], str | None]:
    """Regions of the steps found in one curve: each step (``rise``/``fall``), or for
    ``model="pulse"`` a step and the opposite step after it as one ``pulse``; and why there
    is none (None when there is one)."""
    search = find_steps(t_s, x, min_snr=min_snr, min_points=min_points)
    steps = search.steps
    spans = [(s.start_s, s.end_s, s.label) for s in steps]
    if model == "step":  # the start a first-order step fits best, of the found one +- 1
        spans = [(best_step_start(t_s, x, a, b), b, label) for a, b, label in spans]
    if model == "pulse":  # pair each step with the opposite one after it, left to right
        pulses, k = [], 0
        while k + 1 < len(steps):
            if steps[k + 1].label != steps[k].label:
                pulses.append((steps[k].start_s, steps[k + 1].end_s, "pulse"))
                k += 2
            else:
                k += 1
        spans = pulses
    kept = _numbered([sp for sp in spans if want is None or sp[2] == want])
    if kept:
        return kept, None
    why = search.why_not
    if why is None:  # steps, but none of the kind asked for
        labels = sorted({sp[2] for sp in spans}) or sorted({s.label for s in steps})
        why = (f"no {want or model} region among the steps found "
               f"({', '.join(labels) or 'none paired'})")
    return [], why


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min"


def _check_size(tf: TactileFile, stream: str, *, channels: str | None, reduce: str,
                want: str | None, regions: str, max_curves: int) -> None:
    """Refuse, before any sample is read, more than ``max_curves`` curves to search or fit
    (counted from the channel names and annotations), with the time they would take."""
    searched = fitted = n_channels = 0
    for name in tf.trial_names:
        trial = tf.trial(name)
        if not trial.has_signal(stream):
            continue  # the reading loop says so
        chosen = match_channels(trial.signal_sensor(stream).channel_names, channels)
        n_channels = max(n_channels, len(chosen))
        n = min(len(chosen), 1) if reduce == "mean" else len(chosen)
        spans = sum(1 for a in trial.annotations
                    if want is None or a.label.strip().lower() == want)
        if regions == "detect" or (regions == "auto" and not spans):
            searched += n
            fitted += n  # at least one step each, were one found everywhere
        else:
            fitted += n * spans
    if max(searched, fitted) <= max_curves:
        return
    seconds = searched * SEARCH_S_PER_CURVE + fitted * FIT_S_PER_CURVE
    work = f"{searched:,} curves to search for steps" if searched else f"{fitted:,} curves"
    raise InputError(f"stream {stream!r}: {work} ({len(tf.trial_names)} trial(s) of up to "
                     f"{n_channels:,} channels), more than `max_curves` (={max_curves}); "
                     f"that is about {_duration(seconds)} of work on one core: choose "
                     "channels with `channels` (globs) or fit their mean with "
                     "`reduce='mean'`", path=tf.path)


def read_stream_curves(
    source: str | Path | TactileFile,
    stream: str,
    *,
    channels: str | None = None,
    reduce: str = "none",
    region_label: str | None = None,
    regions: str = "annotations",
    model: str = "step",
    min_snr: float = MIN_SNR,
    min_points: int = 4,
    max_curves: int = MAX_CURVES,
) -> StreamCurves:
    """The responses of ``stream`` over the regions of every trial (see the module doc).
    ``region_label``: only regions with this label (annotations: any label, case and
    surrounding spaces ignored; found regions: ``rise``, ``fall`` or ``pulse``); None: all.

    Raises :class:`InputError` for a file without trials, a trial without the stream, a
    glob that matches no channel, channels of several units averaged, a trial without
    (matching) annotations, a region with fewer than ``min_points`` samples, more than
    ``max_curves`` curves to search or fit (with the time they would take), or no step
    found in any curve of the file.
    """
    if reduce not in REDUCE_MODES:
        raise ValueError(f"`reduce` (={reduce!r}) must be one of {REDUCE_MODES}.")
    if regions not in STREAM_REGION_MODES:
        raise ValueError(f"`regions` (={regions!r}) must be one of {STREAM_REGION_MODES}.")
    if not isinstance(source, TactileFile):
        with TactileFile(source) as tf:
            return read_stream_curves(tf, stream, channels=channels, reduce=reduce,
                                      region_label=region_label, regions=regions,
                                      model=model, min_snr=min_snr, min_points=min_points,
                                      max_curves=max_curves)
    tf, path = source, source.path
    if not tf.trial_names:
        raise InputError("the file has no trials", path=path)
    want = None if region_label is None else region_label.strip().lower()
    found_labels = ("pulse",) if model == "pulse" else ("rise", "fall")
    if regions == "detect" and want is not None and want not in found_labels:
        raise InputError(f"`region_label` (={region_label!r}): regions found in the signal "
                         f"are labelled {' or '.join(found_labels)}", path=path)
    _check_size(tf, stream, channels=channels, reduce=reduce, want=want, regions=regions,
                max_curves=max_curves)
    out: list[StreamCurve] = []
    no_step: list[str] = []
    not_fitted: dict[str, str] = {}
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
        detect = regions == "detect" or (regions == "auto" and not annotations)
        if not detect and not annotations:
            what = "annotations" if want is None else f"annotations labelled {region_label!r}"
            raise InputError(f"no {what} to fit (labels: "
                             f"{', '.join(sorted({a.label for a in trial.annotations})) or 'none'}"
                             "); add them at ingest (`tactile ingest --annotations FILE`) or "
                             "find steps in the signal (`regions='detect'`)",
                             path=path, where=trial.where)
        # all channels: no per-name lookup (76,800 pixels of a height map)
        sig = trial.signal(stream, channels=None if chosen == list(names) else chosen)
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
        shared = None if detect else _numbered([(a.start_s, a.end_s, a.label)
                                                for a in annotations])
        for c, label in enumerate(labels):
            spans = shared
            if spans is None:
                spans, why = _found_regions(sig.t_s, data[:, c], model=model, want=want,
                                            min_snr=min_snr, min_points=min_points)
                if not spans:
                    no_step.append(f"{name}/{label}")
                    not_fitted[f"{name}/{label}"] = why or "no step found"
                    continue
            for start, end, region in spans:
                inside = (sig.t_s >= start) & (sig.t_s < end)
                if inside.sum() < min_points and shared is None:  # a found step: named
                    not_fitted[f"{name}/{label}/{region}"] = (
                        f"holds {int(inside.sum())} samples from its start, {min_points} "
                        "needed")
                    continue
                if inside.sum() < min_points:
                    raise InputError(f"the {region!r} interval [{start:g}, {end:g}) s holds "
                                     f"{int(inside.sum())} samples of stream {stream!r}; at "
                                     f"least {min_points} are needed", path=path,
                                     where=trial.where)
                base = level_before(sig.t_s, data[:, c], start, end)
                out.append(StreamCurve(name, label, region, sig.t_s[inside] - start,
                                       data[inside, c] - base, units[c] or "units", start,
                                       end, base))
    if not out:
        reasons = sorted({why.split(" (")[0].split(":")[0] for why in not_fitted.values()})
        raise InputError(f"no step found in stream {stream!r} ({len(no_step)} curve(s) "
                         f"searched, threshold {min_snr:g} times the noise; "
                         f"{', '.join(reasons) or 'none'}); lower `min_snr` or annotate "
                         "the regions", path=path)
    return StreamCurves(out, no_step, not_fitted)


__all__ = ["MAX_CURVES", "REDUCE_MODES", "STREAM_REGION_MODES", "StreamCurve", "StreamCurves",
           "match_channels", "read_stream_curves"]
