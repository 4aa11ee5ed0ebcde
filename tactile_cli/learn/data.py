"""Datasets from tactile HDF5 files: trials, splits by trial, normalisation and windows.

The pipeline of ``tactile train`` and ``tactile evaluate`` (issue 4, item 2):

1. :func:`read_trials` reads the configured stream of every trial (channels selected by
   name) with its per-sample labels and trial labels, its sample period, channel names
   and units (the run's input, checked by :mod:`.inputs`). A trial with events but no
   ``event_counts`` stream is counted on the fly (contract 2:
   :func:`tactile_cli.events.accumulate.trial_counts`) and labelled per bin from its
   annotations (:func:`~tactile_cli.events.accumulate.counts_to_labels`).
2. :func:`~tactile_cli.learn.splits.assign_splits` divides trials (never windows) into
   train/val/test (attribute, random, stratified or grouped; :mod:`.splits`).
3. :func:`fit_normalisation` takes per-channel mean and standard deviation from the
   training trials' samples only; the statistics are saved with the model.
4. :func:`make_windows` cuts each trial into windows of ``window`` samples whose ends are
   ``stride`` samples apart, with one target per head: the label of the window's last
   sample (minus ``label_delay``; causal, what a real-time user gets) or the window's
   majority label; trial labels are the same for every window of the trial.

Windows are not copied: a :class:`WindowSet` keeps the normalised samples of all trials
back to back and the start index of every window, and gathers a batch on demand.

Label conventions: a per-sample class index below 0 means "unlabelled" (no annotation
covers the sample); windows whose target is unlabelled (or NaN for regression) are left
out, for every head at once.

Summary features (the MLP family, :func:`summary_features`): per channel, over the window,
``mean``, ``std`` (population), ``min``, ``max``, ``last`` (the last sample) and ``slope``
(least-squares slope against the sample index, in normalised units per sample); the
feature vector is feature-major: all channels' means, then all stds, and so on.
"""

from __future__ import annotations

import fnmatch
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..natural import natural_key
from ..store.trials import TactileFile, Trial
from .config import SUMMARY_FEATURES, BaselineConfig, DataConfig, TargetConfig
from .heads import HeadSpec
from .preprocess import normalise_windows, remove_baseline
from .splits import SPLITS, SplitAssignment, assign_splits


@dataclass
class TrialSeries:
    """The selected channels and labels of one trial.

    x: (n, c) float32 samples in the sensor's units (channels in config order).
    t_s: (n,) float64 sample times, seconds from the trial's time origin.
    sample_labels: name -> (n,) per-sample label (int64 class index, -1 = unlabelled, or
    float64 for numeric labels). classes: name -> class names of categorical labels.
    trial_labels: the trial's ``labels`` attributes. split_attr: its ``split`` attribute.
    origin: ``"signal"`` (a stored stream) or ``"events"`` (counted on the fly).
    sensor: the stream's sensor. sample_period_s: seconds between samples (see
    :func:`_sample_period_s`; the bin width for counts from events; NaN when unknown).
    channel_names, channel_units: of the columns of ``x`` (units as recorded in
    ``/sensors/<sensor>/channel_units``, ``""`` where there are none).
    """

    file: str
    trial: str
    split_attr: str
    x: np.ndarray
    t_s: np.ndarray
    sample_labels: dict[str, np.ndarray] = field(default_factory=dict)
    classes: dict[str, tuple[str, ...] | None] = field(default_factory=dict)
    trial_labels: dict[str, Any] = field(default_factory=dict)
    origin: str = "signal"
    sensor: str = ""
    sample_period_s: float = math.nan
    channel_names: tuple[str, ...] = ()
    channel_units: tuple[str, ...] = ()
    time_origin_unix_s: float | None = None
    """The trial's start time (Unix seconds; its ``time_origin_unix_s`` attribute), the
    recording order of ``split: {mode: blocked, by: time_origin_unix_s}`` and of the
    interleaving check of ``tactile evaluate``; None when the file records none."""

    @property
    def key(self) -> str:
        """``<file name>/<trial>``: how the trial is named in splits and predictions."""
        return f"{Path(self.file).name}/{self.trial}"


# -- reading ---------------------------------------------------------------------------------
def data_files(data_paths: Sequence[str | Path]) -> list[Path]:
    """The ``--data`` files as paths; InputError when none is given or one is missing."""
    paths = [Path(p) for p in data_paths]
    if not paths:
        raise InputError("no data files; give `data_paths`")
    for p in paths:
        if not p.is_file():
            raise InputError("data file not found", path=p)
    return paths


_GLOB = set("*?[")


def has_patterns(channels: Sequence[str]) -> bool:
    """Whether any channel name is a glob pattern (holds ``*``, ``?`` or ``[``)."""
    return any(_GLOB & set(c) for c in channels)


def expand_channels(patterns: Sequence[str], names: Sequence[str], *, path: str | Path,
                    where: str) -> list[str]:
    """Channel names and glob patterns -> names, each pattern's matches in the sensor's
    order (``names``), without repeats; a pattern or name that matches nothing is an
    InputError listing the sensor's channels."""
    out: list[str] = []
    for pattern in patterns:
        hits = [n for n in names if fnmatch.fnmatchcase(n, pattern)] \
            if _GLOB & set(pattern) else ([pattern] if pattern in names else [])
        if not hits:
            shown = ", ".join(names[:12]) + (f", ... ({len(names)} in all)"
                                             if len(names) > 12 else "")
            raise InputError(f"channel {pattern!r} matches no channel of the stream "
                             f"(channels: {shown}); fix data.channels", path=path, where=where)
        out += [h for h in hits if h not in out]
    return out


def stream_channel_names(data: DataConfig, path: str | Path) -> tuple[list[str], str]:
    """The channel names of ``data.stream`` (or of the frames input) in the first trial of
    ``path``, and the HDF5 path they were read at; one :class:`InputError` when the file
    has no trials or the trial lacks the stream."""
    path = Path(path)
    with TactileFile(path) as f:
        if not f.trial_names:
            raise InputError("the file has no trials", path=path)
        trial = f.trial(f.trial_names[0])
        if data.frames is not None and trial.has_frames:
            from .frames import frame_channel_names

            return frame_channel_names(data.frames), f"{trial.where}/frames"
        if trial.has_signal(data.stream):
            return (list(trial.signal_sensor(data.stream).channel_names),
                    f"{trial.where}/signals/{data.stream}")
        if data.stream == "event_counts" and trial.has_events:
            return ["positive", "negative", "net"], f"{trial.where}/signals/{data.stream}"
        raise InputError(f"trial has no stream {data.stream!r} (streams: "
                         f"{', '.join(trial.signal_names) or 'none'}); fix data.stream",
                         path=path, where=trial.where)


def resolve_channels(data: DataConfig, paths: Sequence[str | Path]) -> DataConfig:
    """``data`` with glob patterns in ``channels`` replaced by the matching channel names of
    the stream in the first trial of the first file (unchanged when there are none)."""
    if not has_patterns(data.channels):
        return data
    names, where = stream_channel_names(data, paths[0])
    channels = expand_channels(data.channels, names, path=Path(paths[0]), where=where)
    return data.model_copy(update={"channels": channels})


def check_channels(data: DataConfig, path: str | Path, *, what: str = "data.channels"
                   ) -> None:
    """Refuse, before any training, channels (names or glob patterns) that the stream of
    the first trial of ``path`` does not have; ``what`` names where they were given."""
    names, where = stream_channel_names(data, path)
    if has_patterns(data.channels):
        expand_channels(data.channels, names, path=Path(path), where=where)
        return
    missing = [ch for ch in data.channels if ch not in names]
    if missing:
        raise InputError(f"{what}: {', '.join(map(repr, missing))} is not a channel of stream "
                         f"{data.stream!r} (channels: {', '.join(names) or 'none'})",
                         path=Path(path), where=where)


def read_trials(paths: Sequence[str | Path], data: DataConfig, *, trained: bool = False
                ) -> list[TrialSeries]:
    """Every trial of the given files, with the configured stream, channels and the
    sample labels the config's targets need.

    Raises :class:`InputError` naming the file and HDF5 path when a trial lacks the
    stream, a channel or a label (it lists what is there). ``trained``: the data are read
    for a trained run (``data`` is its config), so a missing channel is reported against
    the run's channels rather than as a config to fix.
    """
    sample_targets = [t.name for t in data.targets if t.source == "sample"]
    trials: list[TrialSeries] = []
    for path in paths:
        path = Path(path)
        if not path.exists():
            raise InputError("data file not found", path=path)
        with TactileFile(path) as f:
            if not f.trial_names:
                raise InputError("the file has no trials", path=path)
            for trial in f:
                trials.append(_read_trial(trial, data, sample_targets, trained))
    return trials


def _read_trial(trial: Trial, data: DataConfig, sample_targets: list[str], trained: bool
                ) -> TrialSeries:
    path = trial.path
    if data.frames is not None:
        return _read_frames(trial, data, sample_targets, trained)
    if trial.has_signal(data.stream):
        where = f"{trial.where}/signals/{data.stream}"
        sensor = trial.signal_sensor(data.stream)
        if not sensor.channel_names:
            raise InputError(f"sensor {sensor.name!r} has no channel_names; channels cannot "
                             "be selected by name", path=path, where=f"/sensors/{sensor.name}")
        for ch in data.channels:
            if ch not in sensor.channel_names:
                todo = (f"the run was trained on channels [{', '.join(data.channels)}]; rename "
                        "the data's channels to the run's or retrain on it") if trained \
                    else "fix data.channels"
                raise InputError(f"channel {ch!r} is not a channel of sensor {sensor.name!r} "
                                 f"(channels: {', '.join(sensor.channel_names)}); {todo}",
                                 path=path, where=where)
        signal = trial.signal(data.stream, channels=data.channels)
        labels: dict[str, np.ndarray] = {}
        classes: dict[str, tuple[str, ...] | None] = {}
        available = list(signal.sample_labels)
        for label in sample_targets:
            if label not in available:
                raise InputError(
                    f"no per-sample label {label!r} (labels: {', '.join(available) or 'none'}); "
                    "fix data.targets or use `source: trial` for a trial label",
                    path=path, where=f"{where}/sample_labels")
            values = signal.sample_labels[label].values
            label_classes = signal.sample_labels[label].classes
            classes[label] = label_classes
            labels[label] = values.astype(np.int64) \
                if label_classes is not None or values.dtype.kind in "iub" \
                else values.astype(np.float64)
        return TrialSeries(str(path), trial.name, trial.split,
                           np.ascontiguousarray(signal.data, dtype=np.float32), signal.t_s,
                           labels, classes, trial.labels, "signal", sensor.name,
                           signal.sample_period_s, tuple(data.channels), signal.channel_units,
                           _time_origin(trial))
    if data.stream == "event_counts" and trial.has_events:
        return _count_events(trial, data, sample_targets)
    hint = " and no events to count" if data.stream == "event_counts" else ""
    raise InputError(f"trial has no stream {data.stream!r}{hint} (streams: "
                     f"{', '.join(trial.signal_names) or 'none'}); fix data.stream",
                     path=path, where=trial.where)


def _read_frames(trial: Trial, data: DataConfig, sample_targets: list[str], trained: bool
                 ) -> TrialSeries:
    """A trial's image frames as the series of :mod:`.frames` (``data.stream: frames``)."""
    from .frames import frame_channel_names, frame_series, select_columns

    assert data.frames is not None
    path, where = trial.path, f"{trial.where}/frames"
    if not trial.has_frames:
        raise InputError("trial has no image frames (data.stream: frames needs an image "
                         "recording: ingest image folders or a simulated camera scene)",
                         path=path, where=trial.where)
    if sample_targets:
        raise InputError(f"image frames carry no per-sample labels ({', '.join(sample_targets)}"
                         "); use `source: trial` targets", path=path, where=where)
    names = frame_channel_names(data.frames)
    known = set(names)
    for ch in data.channels:
        if ch not in known:
            todo = "the run was trained on other frame channels; retrain on these data" \
                if trained else "use channels: [\"*\"] or names like " + names[0]
            raise InputError(f"channel {ch!r} is not a pixel of data.frames ({names[0]} ... "
                             f"{names[-1]}); {todo}", path=path, where=where)
    frames = trial.frames()
    x = select_columns(frame_series(frames, data.frames), names, data.channels)
    t_s = np.asarray(frames.t_s, dtype=np.float64)[::data.frames.step]
    steps = np.diff(t_s)
    period = float(np.median(steps)) if steps.size and np.median(steps) > 0 else math.nan
    return TrialSeries(str(path), trial.name, trial.split, x, t_s, {}, {}, trial.labels,
                       "frames", frames.sensor_name, period, tuple(data.channels),
                       (data.frames.unit,) * len(data.channels), _time_origin(trial))


def _count_events(trial: Trial, data: DataConfig, sample_targets: list[str]) -> TrialSeries:
    """Event counts of a trial without an ``event_counts`` stream, with action labels
    from its annotations (contract 2)."""
    from ..events import accumulate  # lazy: only event recordings need it
    from ..vocabulary import ACTIONS

    path, name = trial.path, trial.name
    counts = accumulate.trial_counts(trial, bin_s=data.bin_s)
    annotations = trial.annotations
    stacked = {"positive": counts.positive, "negative": counts.negative, "net": counts.net}
    for ch in data.channels:
        if ch not in stacked:
            raise InputError(f"channel {ch!r} is not an event-count channel (channels: "
                             f"{', '.join(stacked)}); fix data.channels", path=path,
                             where=f"/trials/{name}/events")
    x = np.stack([stacked[ch] for ch in data.channels], axis=1).astype(np.float32)
    labels: dict[str, np.ndarray] = {}
    classes: dict[str, tuple[str, ...] | None] = {}
    for label in sample_targets:
        if label != "action":
            raise InputError(f"per-sample label {label!r} is not available for event counts "
                             "computed from events (only `action`, from the annotations)",
                             path=path, where=f"/trials/{name}")
        if not annotations:
            raise InputError("trial has no annotations, so its bins have no action labels",
                             path=path, where=f"/trials/{name}/annotations")
        labels[label] = accumulate.counts_to_labels(counts.t_s, annotations).astype(np.int64)
        classes[label] = tuple(ACTIONS)
    # the units of the event-count streams that `tactile accumulate` writes
    return TrialSeries(str(path), name, trial.split, x, counts.t_s.astype(np.float64), labels,
                       classes, trial.labels, "events", trial.events.sensor_name,
                       float(counts.bin_s), tuple(data.channels),
                       ("events/bin",) * len(data.channels), _time_origin(trial))


def _time_origin(trial: Trial) -> float | None:
    """The trial attribute ``time_origin_unix_s`` as a finite float, else None."""
    value = trial.attrs.get("time_origin_unix_s")
    try:
        out = float(value) if value is not None else math.nan
    except (TypeError, ValueError):
        return None
    return out if math.isfinite(out) else None


# -- heads and targets -----------------------------------------------------------------------
def resolve_heads(targets: Sequence[TargetConfig], trials: Sequence[TrialSeries]
                  ) -> list[HeadSpec]:
    """The output heads of the config's targets, with class names taken from the data.

    Sample labels with a ``classes`` attribute use it (it must be the same in every trial);
    a categorical trial label's classes are its distinct values, sorted.
    """
    heads = []
    for target in targets:
        classes: tuple[str, ...] = ()
        if target.kind == "classification":
            if target.source == "sample":
                classes = _sample_classes(target.name, trials)
            else:
                values = {_trial_value(t, target.name) for t in trials}
                classes = tuple(sorted((str(v) for v in values), key=natural_key))
            if len(classes) < 2:
                raise InputError(f"target {target.name!r} has {len(classes)} class(es) "
                                 f"({', '.join(classes)}); a classifier needs at least 2")
        heads.append(HeadSpec(target.name, target.kind, target.source, target.weight, classes))
    return heads


def _sample_classes(name: str, trials: Sequence[TrialSeries]) -> tuple[str, ...]:
    found: tuple[str, ...] | None = None
    first = None
    for t in trials:
        classes = t.classes.get(name)
        if classes is None:
            top = int(t.sample_labels[name].max(initial=-1))
            classes = tuple(str(i) for i in range(top + 1))
        if found is None:
            found, first = classes, t
        elif classes != found and t.classes.get(name) is not None:
            raise InputError(f"label {name!r} has classes {list(classes)} here but "
                             f"{list(found)} in {first.key if first else '?'}; the files "
                             "must use the same classes", path=t.file, where=f"/trials/{t.trial}")
    return found or ()


def _trial_value(trial: TrialSeries, name: str) -> Any:
    if name not in trial.trial_labels:
        raise InputError(f"no trial label {name!r} (labels: "
                         f"{', '.join(trial.trial_labels) or 'none'}); fix data.targets",
                         path=trial.file, where=f"/trials/{trial.trial}/labels")
    return trial.trial_labels[name]


def check_heads_match(heads: Sequence[HeadSpec], trials: Sequence[TrialSeries], *,
                      stream: str | None = None) -> None:
    """Raise when evaluation data use other class names than the run's heads, or give no
    class names where the run was trained on named classes (``stream``: the stream the
    labels belong to, for the HDF5 path in the message)."""
    for head in heads:
        if head.kind != "classification" or head.source != "sample":
            continue
        numbered = head.classes == tuple(str(i) for i in range(len(head.classes)))
        for t in trials:
            classes = t.classes.get(head.name)
            if classes is None and not numbered:
                where = (f"/trials/{t.trial}/signals/{stream}/sample_labels/{head.name}"
                         if stream else f"/trials/{t.trial}")
                raise InputError(f"label {head.name!r} has no `classes` attribute, but the run "
                                 f"was trained on classes {list(head.classes)}; give the "
                                 "label its class names (as the training data did)",
                                 path=t.file, where=where)
            if classes is not None and classes != head.classes:
                raise InputError(f"label {head.name!r} has classes {list(classes)}; the run "
                                 f"was trained on {list(head.classes)}", path=t.file,
                                 where=f"/trials/{t.trial}")


def per_sample_targets(trial: TrialSeries, heads: Sequence[HeadSpec]) -> dict[str, np.ndarray]:
    """name -> (n,) target per sample: int64 class index (-1 unlabelled) or float64 value."""
    n = trial.x.shape[0]
    out: dict[str, np.ndarray] = {}
    for head in heads:
        if head.source == "sample":
            values = trial.sample_labels[head.name]
            if values.shape != (n,):
                raise InputError(f"label {head.name!r} has {values.shape[0]} values for {n} "
                                 "samples", path=trial.file, where=f"/trials/{trial.trial}")
            if head.kind == "classification":
                values = values.astype(np.int64)
                if values.max(initial=-1) >= len(head.classes):
                    raise InputError(f"label {head.name!r} holds class index "
                                     f"{int(values.max())} but has {len(head.classes)} classes",
                                     path=trial.file, where=f"/trials/{trial.trial}")
            else:
                values = values.astype(np.float64)
            out[head.name] = values
            continue
        value = _trial_value(trial, head.name)
        if head.kind == "classification":
            if str(value) not in head.classes:
                raise InputError(f"trial label {head.name}={value!r} is not one of the run's "
                                 f"classes ({', '.join(head.classes)})", path=trial.file,
                                 where=f"/trials/{trial.trial}/labels")
            out[head.name] = np.full(n, head.classes.index(str(value)), dtype=np.int64)
        else:
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise InputError(f"trial label {head.name}={value!r} is not a number; a "
                                 "regression target must be numeric", path=trial.file,
                                 where=f"/trials/{trial.trial}/labels") from None
            out[head.name] = np.full(n, number, dtype=np.float64)
    return out


# -- normalisation ---------------------------------------------------------------------------
@dataclass
class Normalisation:
    """Per-channel standardisation ``(f(x) - mean) / std`` and regression-target scaling.

    f is ``transform`` (see :func:`transform_samples`). mean, std: (c,) float64 of f(x)
    over the training trials' samples (padding excluded); a channel
    with zero or non-finite spread gets std 1. ``targets``: regression head name ->
    (mean, std) of its training targets. ``features``: the MLP's summary-feature mean and
    std (also inside the model's state dict), for the record.
    """

    channels: list[str]
    mean: np.ndarray
    std: np.ndarray
    n_samples: int
    enabled: bool = True
    transform: str = "none"
    targets: dict[str, tuple[float, float]] = field(default_factory=dict)
    features: dict[str, list[float]] | None = None

    def apply(self, x: np.ndarray) -> np.ndarray:
        """(n, c) samples in sensor units -> (n, c) float32, transformed and standardised."""
        y = transform_samples(x, self.transform)
        if not self.enabled:
            return y.astype(np.float32)
        return ((y - self.mean) / self.std).astype(np.float32)

    def as_dict(self) -> dict[str, Any]:
        return {
            "format": "tactile-normalisation", "format_version": 1,
            "enabled": self.enabled, "transform": self.transform,
            "channels": list(self.channels),
            "mean": [float(v) for v in self.mean], "std": [float(v) for v in self.std],
            "n_samples": int(self.n_samples),
            "targets": {k: {"mean": m, "std": s} for k, (m, s) in self.targets.items()},
            "features": self.features,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Normalisation:
        return cls(
            channels=list(d["channels"]), mean=np.asarray(d["mean"], dtype=np.float64),
            std=np.asarray(d["std"], dtype=np.float64), n_samples=int(d["n_samples"]),
            enabled=bool(d["enabled"]), transform=str(d["transform"]),
            targets={k: (float(v["mean"]), float(v["std"])) for k, v in d["targets"].items()},
            features=d.get("features"),
        )

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=2)


def transform_samples(x: np.ndarray, transform: str) -> np.ndarray:
    """(n, c) -> (n, c) float64: ``none`` or ``signed_log1p`` (``sign(x) log(1 + |x|)``)."""
    y = np.asarray(x, dtype=np.float64)
    if transform == "none":
        return y
    if transform == "signed_log1p":
        return np.sign(y) * np.log1p(np.abs(y))
    raise ValueError(f"`transform` (={transform!r}) must be none or signed_log1p")


def trial_samples(trial: TrialSeries, baseline: BaselineConfig | None = None) -> np.ndarray:
    """(n, c) float32 samples of a trial in sensor units, minus its resting level when
    ``baseline`` (``data.baseline``) asks for it (:func:`.preprocess.remove_baseline`)."""
    if baseline is None or baseline.mode == "none":
        return trial.x
    return remove_baseline(trial.x, trial.t_s, mode=baseline.mode,
                           duration_ms=baseline.duration_ms)


def fit_normalisation(train: Sequence[TrialSeries], channels: Sequence[str], *,
                      enabled: bool = True, transform: str = "none",
                      baseline: BaselineConfig | None = None) -> Normalisation:
    """Per-channel mean and std over every (baseline-removed, transformed) sample of the
    training trials."""
    if not train:
        raise InputError("no training trials to take normalisation statistics from")
    x = transform_samples(np.concatenate([trial_samples(t, baseline) for t in train], axis=0),
                          transform)
    mean = x.mean(axis=0)
    std = x.std(axis=0)
    std = np.where(np.isfinite(std) & (std > 0), std, 1.0)
    return Normalisation(list(channels), mean, std, int(x.shape[0]), enabled, transform)


# -- windows ---------------------------------------------------------------------------------
def trial_groups(trials: Sequence[TrialSeries], data: DataConfig) -> list[str] | None:
    """The ``data.decide_by`` label of every trial (as text, in order), or None when the
    config decides per trial only; InputError naming a trial without the label."""
    if data.decide_by is None:
        return None
    out = []
    for t in trials:
        if data.decide_by not in t.trial_labels:
            raise InputError(f"trial has no label {data.decide_by!r} (labels: "
                             f"{', '.join(t.trial_labels) or 'none'}); fix data.decide_by or "
                             "label every trial", path=t.file, where=f"/trials/{t.trial}")
        out.append(str(t.trial_labels[data.decide_by]))
    return out


@dataclass
class WindowSet:
    """Windows of several trials without copies.

    x: (n_total, c) float32 normalised samples of all trials back to back (each trial
    preceded by its padding); starts: (n_windows,) index into x of each window's first
    sample. targets: head name -> (n_windows,) int64 class index or float32 value
    (regression values standardised when the normalisation has target statistics).
    trial_index: (n_windows,) index into ``trials``; end_index: (n_windows,) index of the
    window's last sample within its trial; target_index: the sample the target belongs to;
    target_t_s: its time in seconds. near_boundary: sample-classification head name ->
    (n_windows,) bool, the target sample lies within ``boundary_margin`` samples of a label
    change.
    """

    x: np.ndarray
    starts: np.ndarray
    window: int
    targets: dict[str, np.ndarray]
    trial_index: np.ndarray
    end_index: np.ndarray
    target_index: np.ndarray
    target_t_s: np.ndarray
    near_boundary: dict[str, np.ndarray]
    trials: list[str]  # TrialSeries.key of each trial
    label_changes: dict[str, bool] = field(default_factory=dict)
    """Sample-classification head name -> whether any trial's labels change inside the
    trial (a time series with transitions; the boundary metric means something only then)."""
    window_norm: str = "none"
    """Per-window transform applied by :meth:`windows` (see :func:`center_scale`)."""

    def __len__(self) -> int:
        return int(self.starts.shape[0])

    @property
    def n_channels(self) -> int:
        return int(self.x.shape[1])

    def windows(self, idx: np.ndarray | slice | None = None) -> np.ndarray:
        """(k, window, c) float32 windows ``idx`` (all when None)."""
        starts = self.starts if idx is None else self.starts[idx]
        out = self.x[starts[:, None] + np.arange(self.window)]
        return self.normalise(out)

    def raw_windows(self, idx: np.ndarray | slice | None = None) -> np.ndarray:
        """(k, window, c) float32 windows ``idx`` before the per-window normalisation
        (what training augments before :meth:`normalise`)."""
        starts = self.starts if idx is None else self.starts[idx]
        return self.x[starts[:, None] + np.arange(self.window)]

    def normalise(self, windows: np.ndarray) -> np.ndarray:
        """The per-window normalisation ``window_norm`` of (k, window, c) windows."""
        if self.window_norm == "center_scale":
            return center_scale(windows)
        return normalise_windows(windows, self.window_norm)

    def subset(self, mask: np.ndarray) -> WindowSet:
        """The windows where ``mask`` (n_windows,) is true (sharing ``x``)."""
        return WindowSet(self.x, self.starts[mask], self.window,
                         {k: v[mask] for k, v in self.targets.items()}, self.trial_index[mask],
                         self.end_index[mask], self.target_index[mask], self.target_t_s[mask],
                         {k: v[mask] for k, v in self.near_boundary.items()}, self.trials,
                         dict(self.label_changes), self.window_norm)


def center_scale(windows: np.ndarray) -> np.ndarray:
    """(k, w, c) windows -> (k, w, c) float32 with each channel of each window centred on
    its mean and divided by its largest absolute deviation, so that it spans [-1, 1]
    (paper 001, sec. 4); a channel constant over its window becomes all zeros (tested on
    its range: the float32 mean of equal values can differ from them by a rounding step,
    and that step divided by itself would give +-1)."""
    x = np.asarray(windows, dtype=np.float32)
    varies = x.max(axis=1, keepdims=True) > x.min(axis=1, keepdims=True)
    x = x - x.mean(axis=1, keepdims=True)
    peak = np.abs(x).max(axis=1, keepdims=True)
    return np.divide(x, peak, out=np.zeros_like(x), where=varies & (peak > 0))


def window_ends(n_samples: int, data: DataConfig) -> np.ndarray:
    """(k,) index (within the trial) of the last sample of each window of a trial of
    ``n_samples`` samples: every ``stride`` samples from the first sample that has a full
    window (``window - 1`` unpadded, ``label_delay`` padded), or with ``align: end`` every
    ``stride`` samples back from the last sample down to that first one, in time order."""
    first = data.label_delay if data.pad != "none" else data.window - 1
    if data.align == "end":
        return np.arange(n_samples - 1, first - 1, -data.stride, dtype=np.int64)[::-1].copy()
    return np.arange(first, n_samples, data.stride, dtype=np.int64)


def _near_change(labels: np.ndarray, margin: int) -> np.ndarray:
    """(n,) bool: the labels within ``margin`` samples of each sample are not all equal."""
    n = labels.shape[0]
    change = np.zeros(n + 1, dtype=np.int64)  # change[i + 1]: labels[i] != labels[i + 1]
    change[2:] = np.cumsum(labels[1:] != labels[:-1])
    # changes between samples j - margin .. j + margin: pairs (i, i + 1) with i in
    # [j - margin, j + margin - 1]
    j = np.arange(n)
    lo = np.clip(j - margin, 0, n - 1)
    hi = np.clip(j + margin, 0, n - 1)
    return (change[hi + 1] - change[lo + 1]) > 0


def windowless_note(trials: Sequence[TrialSeries], ws: WindowSet, window: int) -> list[str]:
    """One note naming the trials of ``trials`` that gave no window in ``ws`` (so no
    decision and no score), or [] when every trial gave one: a trial shorter than the
    window without ``pad``, or one without a labelled sample, is left out of every metric,
    and a per-trial accuracy is then over fewer trials than the data hold."""
    have = {ws.trials[i] for i in np.unique(ws.trial_index)} if len(ws) else set()
    left = [t.key for t in trials if t.key not in have]
    if not left:
        return []
    names = ", ".join(left[:3]) + (f" and {len(left) - 3} more" if len(left) > 3 else "")
    return [f"{len(left)} of {len(trials)} trials give no window and are not scored "
            f"({names}): shorter than the window of {window} samples (data.pad: none), or "
            "without a labelled sample"]


def make_windows(trials: Sequence[TrialSeries], data: DataConfig, heads: Sequence[HeadSpec],
                 norm: Normalisation) -> WindowSet:
    """Cut trials into windows with one target per head (see the module docstring)."""
    w = data.window
    pad = w - 1 if data.pad != "none" else 0
    xs, starts, trial_idx, ends, tgt_idx, tgt_t = [], [], [], [], [], []
    targets: dict[str, list[np.ndarray]] = {h.name: [] for h in heads}
    near: dict[str, list[np.ndarray]] = {
        h.name: [] for h in heads if h.kind == "classification" and h.source == "sample"}
    changes = dict.fromkeys(near, False)
    offset = 0
    for i, trial in enumerate(trials):
        n = trial.x.shape[0]
        raw = trial_samples(trial, data.baseline)
        if pad:
            filler = np.zeros((pad, raw.shape[1]), np.float32) if data.pad == "zero" \
                else np.repeat(raw[:1], pad, axis=0)
            raw = np.concatenate([filler, raw], axis=0) if n else raw[:0]
        xs.append(norm.apply(raw))
        e = window_ends(n, data)
        per_sample = per_sample_targets(trial, heads)
        keep = np.ones(e.shape[0], dtype=bool)
        values: dict[str, np.ndarray] = {}
        for head in heads:
            lab = per_sample[head.name]
            if data.label_rule == "last" or head.source == "trial":
                v = lab[e - data.label_delay]
            elif head.kind == "classification":
                v = _majority(lab, e, w, len(head.classes))
            else:
                v = _window_mean(lab, e, w)
            keep &= (v >= 0) if head.kind == "classification" else np.isfinite(v)
            values[head.name] = v
        e = e[keep]
        target = e - data.label_delay
        for head in heads:
            v = values[head.name][keep]
            if head.kind == "regression" and head.name in norm.targets:
                m, s = norm.targets[head.name]
                v = (v - m) / s
            targets[head.name].append(v.astype(np.int64 if head.kind == "classification"
                                               else np.float32))
            if head.name in near:
                lab = per_sample[head.name]
                labelled = lab[lab >= 0]
                changes[head.name] |= bool((labelled[1:] != labelled[:-1]).any())
                near[head.name].append(_near_change(lab, data.boundary_margin)[target])
        starts.append(offset + e + pad - (w - 1))
        trial_idx.append(np.full(e.shape[0], i, dtype=np.int64))
        ends.append(e)
        tgt_idx.append(target)
        tgt_t.append(trial.t_s[target])
        offset += n + pad if n else 0

    def cat(parts: list[np.ndarray], dtype: Any) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype)

    c = len(data.channels)
    return WindowSet(
        x=np.concatenate(xs, axis=0) if xs else np.zeros((0, c), np.float32),
        starts=cat(starts, np.int64), window=w,
        targets={k: cat(v, np.int64 if any(h.name == k and h.kind == "classification"
                                           for h in heads) else np.float32)
                 for k, v in targets.items()},
        trial_index=cat(trial_idx, np.int64), end_index=cat(ends, np.int64),
        target_index=cat(tgt_idx, np.int64), target_t_s=cat(tgt_t, np.float64),
        near_boundary={k: cat(v, bool) for k, v in near.items()},
        trials=[t.key for t in trials], label_changes=changes, window_norm=data.window_norm,
    )


def _majority(labels: np.ndarray, ends: np.ndarray, window: int, n_classes: int) -> np.ndarray:
    """(k,) most frequent class among the labelled samples of each window (lowest index on
    ties; -1 when no sample is labelled). Padding samples carry no label."""
    n = labels.shape[0]
    onehot = np.zeros((n, n_classes), dtype=np.int64)
    valid = labels >= 0
    onehot[np.flatnonzero(valid), labels[valid]] = 1
    cum = np.concatenate([np.zeros((1, n_classes), np.int64), np.cumsum(onehot, axis=0)])
    counts = cum[ends + 1] - cum[np.maximum(ends - window + 1, 0)]
    out = counts.argmax(axis=1)
    return np.where(counts.sum(axis=1) > 0, out, -1)


def _window_mean(values: np.ndarray, ends: np.ndarray, window: int) -> np.ndarray:
    cum = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.maximum(ends - window + 1, 0)
    return (cum[ends + 1] - cum[lo]) / (ends + 1 - lo)


def regression_stats(ws: WindowSet, heads: Sequence[HeadSpec]) -> dict[str, tuple[float, float]]:
    """(mean, std) of each regression head's (unscaled) targets in ``ws``."""
    out = {}
    for head in heads:
        if head.kind == "regression":
            v = ws.targets[head.name].astype(np.float64)
            std = float(v.std()) if v.size else 1.0
            out[head.name] = (float(v.mean()) if v.size else 0.0,
                              std if np.isfinite(std) and std > 0 else 1.0)
    return out


def class_weights(y: np.ndarray, n_classes: int) -> np.ndarray:
    """(n_classes,) inverse-frequency weights ``n / (k n_c)`` over the k classes present
    (a class absent from ``y`` gets 0), so that each present class counts equally."""
    counts = np.bincount(y, minlength=n_classes).astype(np.float64)
    present = counts > 0
    out = np.zeros(n_classes)
    out[present] = y.shape[0] / (present.sum() * counts[present])
    return out


def summary_features(windows: np.ndarray, names: Sequence[str] = SUMMARY_FEATURES
                     ) -> np.ndarray:
    """(k, w, c) windows -> (k, len(names) * c) summary features, feature-major (numpy
    reference of the MLP's in-model feature layer)."""
    x = np.asarray(windows, dtype=np.float64)
    w = x.shape[1]
    idx = np.arange(w, dtype=np.float64) - (w - 1) / 2
    denom = float((idx**2).sum()) or 1.0
    def moment(order: int) -> np.ndarray:
        centred = x - x.mean(axis=1, keepdims=True)
        var = (centred**2).mean(axis=1)
        m = (centred**order).mean(axis=1)
        ok = (x.max(axis=1) > x.min(axis=1)) & (var > 0)  # constant: 0 (see models._moment)
        out = np.divide(m, np.where(ok, var, 1.0) ** (order / 2), out=np.zeros_like(m),
                        where=ok)
        return out - 3.0 * ok if order == 4 else out

    funcs = {
        "mean": lambda: x.mean(axis=1), "std": lambda: x.std(axis=1),
        "min": lambda: x.min(axis=1), "max": lambda: x.max(axis=1),
        "last": lambda: x[:, -1], "slope": lambda: np.einsum("kwc,w->kc", x, idx) / denom,
        "range": lambda: x.max(axis=1) - x.min(axis=1),
        "diff_std": lambda: np.diff(x, axis=1).std(axis=1) if w > 1
        else np.zeros((x.shape[0], x.shape[2])),
        "skew": lambda: moment(3), "kurtosis": lambda: moment(4),
    }
    return np.concatenate([funcs[n]() for n in names], axis=1).astype(np.float32)


__all__ = ["SPLITS", "Normalisation", "SplitAssignment", "TrialSeries",
           "WindowSet", "assign_splits", "center_scale", "check_heads_match", "class_weights",
           "data_files",
           "fit_normalisation", "make_windows", "per_sample_targets", "read_trials",
           "windowless_note",
           "trial_samples",
           "regression_stats", "resolve_heads", "summary_features", "transform_samples",
           "window_ends"]
