"""Accumulate (and segment) every trial of a tactile HDF5 file; write the count streams.

The library side of ``tactile accumulate``: :func:`accumulate_file` turns each trial's
events into :class:`~tactile_cli.events.accumulate.EventCounts`, smooths the net count,
optionally segments it (:func:`~tactile_cli.events.segment.segment_actions`) and scores the
segmentation against the trial's annotations; :func:`write_counts` stores the counts as
``/trials/{trial}/signals/event_counts`` streams (data contract 3 of the toolkit: channels
positive, negative, net in events/bin, ``t_s`` bin centres, ``sample_labels/action``);
:func:`bin_rows` flattens them for a CSV.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..input_guard import check_outputs, overlap
from ..progress import NullProgress, Progress
from ..store.atomic import atomic_file, check_output_file
from ..store.trials import Annotation, TactileFile, Trial
from ..store.writer import StoreWriter
from ..vocabulary import ACTIONS, BIN_S
from .accumulate import (
    CHANNELS,
    MAX_BIN_S,
    EventCounts,
    bin_us_of,
    centred_moving_average,
    counts_to_labels,
    trial_counts,
)
from .segment import Segmentation, SegmentationScore, segment_actions, segmentation_accuracy

#: Name of the count streams (and of their sensor when the source has one event sensor).
STREAM = "event_counts"


@dataclass
class TrialAccumulation:
    """Counts, smoothing and segmentation of one trial.

    smoothed: (n_bins,) float64 centred moving average of the net count over
    ``smooth_bins`` bins.
    true_labels: (n_bins,) int8 action per bin from the trial's annotations (None when the
    trial has no action annotations). segmentation / score: None unless segmenting
    (score also needs annotations).
    """

    trial: str
    sensor: str
    counts: EventCounts
    smoothed: np.ndarray
    smooth_bins: int
    labels: dict[str, Any]
    split: str
    annotations: list[Annotation]
    true_labels: np.ndarray | None
    segmentation: Segmentation | None = None
    score: SegmentationScore | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready per-trial summary (no per-bin arrays)."""
        c = self.counts
        out: dict[str, Any] = {
            "trial": self.trial,
            "n_bins": c.n_bins,
            "duration_s": c.end_s,
            "n_events": c.n_events,
            "n_positive": int(c.positive.sum()),
            "n_negative": int(c.negative.sum()),
            "n_outside": c.n_outside,
            "t_origin_us": c.start_us,
            "peak_net": int(c.net.max()) if c.n_bins else None,
            "annotated": self.true_labels is not None,
            "labels": self.labels,
        }
        if self.segmentation is not None:
            out["segmentation"] = self.segmentation.as_dict()
        if self.score is not None:
            out["bin_accuracy"] = _finite(self.score.bin_accuracy)
            out["boundary_errors_s"] = dict(zip(
                ACTIONS[1:],  # boundary k starts action k
                (_finite(float(e)) for e in self.score.boundary_errors_s), strict=True))
        return out


@dataclass
class FileAccumulation:
    """Every accumulated trial of one file, with the settings used."""

    path: Path
    bin_s: float
    smooth_bins: int
    segmented: bool
    trials: list[TrialAccumulation] = field(default_factory=list)
    sensors: dict[str, tuple[int, int]] = field(default_factory=dict)  # name -> (w, h) px
    skipped: list[str] = field(default_factory=list)  # trials without events (not named)
    written: list[Path] = field(default_factory=list)  # the `out` and `csv` files written
    figures: list[Path] = field(default_factory=list)  # the PNGs written into `plot`

    def summary(self) -> dict[str, Any]:
        scores = [t.score.bin_accuracy for t in self.trials
                  if t.score is not None and math.isfinite(t.score.bin_accuracy)]
        statuses: dict[str, int] = {}
        for t in self.trials:
            if t.segmentation is not None:
                statuses[t.segmentation.status] = statuses.get(t.segmentation.status, 0) + 1
        return {
            "n_trials": len(self.trials),
            "n_skipped_without_events": len(self.skipped),
            "segmentation_status": statuses,
            "mean_bin_accuracy": float(np.mean(scores)) if scores else None,
            "min_bin_accuracy": float(np.min(scores)) if scores else None,
        }

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready results (non-finite numbers become None)."""
        return _json_safe({
            "file": str(self.path),
            "bin_s": self.bin_s,
            "smooth_bins": self.smooth_bins,
            "segment": self.segmented,
            "trials": [t.summary() for t in self.trials],
            "skipped": self.skipped,
            "summary": self.summary(),
            "written": [str(p) for p in self.written],
        })


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _select_trials(tf: TactileFile, trials: Sequence[str] | None
                   ) -> tuple[list[Trial], list[str]]:
    """(trials to accumulate, names of the trials skipped for having no events)."""
    if trials:
        return tf.trials(trials), []
    with_events = [t for t in tf.trials() if t.has_events and t.events.n_events > 0]
    if not with_events:
        raise InputError("no trial has events (event counts need an event-camera recording)",
                         path=tf.path)
    kept = {t.name for t in with_events}
    return with_events, [n for n in tf.trial_names if n not in kept]


def _accumulate_trial(trial: Trial, *, bin_s: float, smooth_bins: int, segment: bool
                      ) -> TrialAccumulation:
    """Counts, smoothing and (with ``segment``) the scored segmentation of one trial."""
    counts = trial_counts(trial, bin_s=bin_s)
    annotations = trial.annotations
    truth = counts_to_labels(counts.t_s, annotations)
    acc = TrialAccumulation(
        trial=trial.name, sensor=trial.events.sensor_name if trial.has_events else "",
        counts=counts, smoothed=centred_moving_average(counts.net, smooth_bins),
        smooth_bins=smooth_bins, labels=trial.labels, split=trial.split,
        annotations=annotations, true_labels=truth if (truth >= 0).any() else None,
    )
    if segment:
        acc.segmentation = segment_actions(counts.net, bin_s=bin_s, smooth_bins=smooth_bins)
        if acc.true_labels is not None:
            acc.score = segmentation_accuracy(acc.segmentation.labels, acc.true_labels,
                                              bin_s=bin_s)
    return acc


def _check_outputs(path: Path, *, out: Path | None, csv: Path | None, plot: Path | None,
                   overwrite: bool) -> None:
    """Every output refused before any work: an input, a folder where a file goes (or
    the reverse), an existing file without ``overwrite``, a place that cannot be written,
    or one file named twice."""
    from ..store.outdir import check_output_folder

    check_outputs({"out": out, "csv": csv, "plot": plot}, [path])
    if out is not None and csv is not None and overlap(out, csv) == "is":
        raise InputError("`out` and `csv` name the same file; give two names", path=out)
    if plot is not None:  # figures are added to an existing folder; a file there is not
        check_output_folder(plot, merge=True)
    for name, target in (("out", out), ("csv", csv)):
        if target is not None and target.is_file() and not overwrite:
            raise InputError(f"`{name}` output exists; pass `overwrite=True` to replace it",
                             path=target)
        if target is not None:
            check_output_file(target, overwrite=overwrite)


def accumulate_file(
    path: str | Path,
    *,
    trials: Sequence[str] | None = None,
    bin_s: float = BIN_S,
    smooth_bins: int = 5,
    segment: bool = False,
    out: str | Path | None = None,
    csv: str | Path | None = None,
    plot: str | Path | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> FileAccumulation:
    """Event counts of the named trials of a tactile file (all trials with events when
    ``trials`` is empty), their centred moving average of ``smooth_bins`` (odd) bins and,
    with ``segment``, their action segmentation scored against the annotations.

    Outputs, all checked before any work (an input, an existing file without
    ``overwrite``, a place that cannot be written: one :class:`InputError`): ``out`` a new
    tactile file of the count streams (:func:`write_counts`), ``csv`` one row per bin
    (:func:`write_bins_csv`), ``plot`` a folder of one Fig. 10-style PNG per trial, each
    written atomically; the paths are in the result's ``written`` and ``figures``.

    Raises :class:`InputError` for a file that is not a tactile file, an unknown trial, a
    named trial without events, or a bin width that is not a whole number of microseconds.
    """
    path = Path(path)
    out, csv, plot = (None if p is None else Path(p) for p in (out, csv, plot))
    progress = progress or NullProgress()
    try:
        bin_us_of(bin_s)
    except ValueError as exc:
        if bin_s > 0 and bin_s * 1e6 >= 1 and bin_s <= MAX_BIN_S:
            raise InputError(f"bin width {bin_s * 1e3:g} ms is not a whole number of "
                             "microseconds; pass e.g. `bin_s=0.02`") from None
        raise InputError(str(exc)) from None
    if smooth_bins < 1:
        raise InputError(f"`smooth_bins` (={smooth_bins}) must be an odd number of bins >= 1 "
                         "(a centred moving average); pass e.g. `smooth_bins=5`")
    if smooth_bins % 2 == 0:
        raise InputError(f"`smooth_bins` (={smooth_bins}) must be odd (a centred moving "
                         f"average); pass e.g. `smooth_bins={smooth_bins + 1}`")
    if not path.is_file():
        raise InputError("file not found", path=path)
    _check_outputs(path, out=out, csv=csv, plot=plot, overwrite=overwrite)
    run = _accumulate(path, trials=trials, bin_s=bin_s, smooth_bins=smooth_bins,
                      segment=segment, progress=progress)
    if plot is not None:
        run.figures = _plot_trials(run, plot, progress)
    if out is not None:
        config = {"file": str(path), "trials": list(trials) if trials else None,
                  "bin_s": float(bin_s), "smooth_bins": smooth_bins, "segment": segment}
        run.written.append(write_counts(run, out, config=config, overwrite=overwrite))
    if csv is not None:
        run.written.append(write_bins_csv(run, csv, overwrite=overwrite))
    return run


def _plot_trials(run: FileAccumulation, plot: Path, progress: Progress) -> list[Path]:
    """One PNG per trial into ``plot``, built aside and merged in when all are drawn."""
    from ..interrupt import raise_if_requested
    from ..store.outdir import output_folder
    from .figure import plot_trial

    progress.start(len(run.trials), "plotting trials")
    figures = []
    with output_folder(plot, merge=True) as tmp:  # in place when every one is
        for acc in run.trials:
            raise_if_requested()
            figures.append(plot / plot_trial(acc, tmp).name)
            progress.advance(1)
    progress.finish()
    return figures


def _accumulate(path: Path, *, trials: Sequence[str] | None, bin_s: float, smooth_bins: int,
                segment: bool, progress: Progress) -> FileAccumulation:
    with TactileFile(path) as tf:
        selected, skipped = _select_trials(tf, trials)
        sensors = {}
        for trial in selected:
            sensor = trial.events.sensor_name if trial.has_events else ""
            if sensor and sensor in tf.sensor_names:
                attrs = tf.sensor(sensor).attrs
                sensors[sensor] = (int(attrs["width_px"]), int(attrs["height_px"]))
        run = FileAccumulation(path, float(bin_s), int(smooth_bins), segment, sensors=sensors,
                               skipped=skipped)
        progress.start(len(selected), "accumulating trials")
        for trial in selected:
            run.trials.append(_accumulate_trial(trial, bin_s=bin_s, smooth_bins=smooth_bins,
                                                segment=segment))
            progress.advance(1)
    progress.finish()
    return run


def write_counts(
    run: FileAccumulation,
    out: str | Path,
    *,
    command: str | None = None,
    config: dict[str, Any] | None = None,
    overwrite: bool = False,
) -> Path:
    """Write the count streams of ``run`` into a new schema-valid tactile file ``out``.

    One sensor ``event_counts`` (``event_counts_<source sensor>`` when the source has
    several event sensors) of kind event_camera with the source sensor's size, channels
    positive/negative/net in events/bin, ``sample_rate_hz = 1/bin_s`` and attribute
    ``bin_s``. Per trial: the labels, split and annotations of the source, the stream
    ``signals/event_counts`` with ``sample_labels/action`` (from the annotations, else from
    a successful segmentation) and ``sample_labels/action_detected`` (the segmentation,
    when it did not fail); segmentation results as stream attributes. The source file is
    recorded in the provenance.
    """
    sensor_names = {s: STREAM if len(run.sensors) <= 1 else f"{STREAM}_{s}" for s in run.sensors}
    with StoreWriter(out, command=command, config=config, overwrite=overwrite) as w:
        source = w.add_source(run.path)
        for src, (width, height) in run.sensors.items():
            w.add_sensor(
                sensor_names[src], kind="event_camera", sample_rate_hz=1.0 / run.bin_s,
                channel_names=list(CHANNELS), channel_units="events/bin",
                width_px=width, height_px=height, bin_s=run.bin_s, source_sensor=src,
                description=f"events of {src} accumulated in {run.bin_s * 1e3:g} ms bins",
            )
        for acc in run.trials:
            trial = w.trial(acc.trial, labels=acc.labels, split=acc.split, sources=[source],
                            annotations=acc.annotations, duration_s=acc.counts.end_s)
            seg = acc.segmentation
            sample_labels: dict[str, tuple[np.ndarray, Sequence[str] | None]] = {}
            detected = seg.labels if seg is not None and seg.status != "failed" else None
            action = acc.true_labels if acc.true_labels is not None else detected
            if action is not None:
                sample_labels["action"] = (action.astype(np.int8), ACTIONS)
            if detected is not None:
                sample_labels["action_detected"] = (detected.astype(np.int8), ACTIONS)
            group = trial.write_signal(
                STREAM, sensor=sensor_names[acc.sensor], data=acc.counts.stack(),
                t_s=acc.counts.t_s, sample_labels=sample_labels,
            )
            group.attrs["t_origin_us"] = np.int64(acc.counts.start_us)
            group.attrs["n_outside_events"] = np.int64(acc.counts.n_outside)
            group.attrs["action_source"] = (
                "annotations" if acc.true_labels is not None
                else "segmentation" if detected is not None else "none")
            if seg is not None:
                group.attrs["segmentation_status"] = seg.status
                group.attrs["segmentation_message"] = seg.message
                for key in ("press_start_s", "slip_start_s", "release_start_s"):
                    group.attrs[key] = float(getattr(seg, key))
        return w.commit()


def bin_rows(run: FileAccumulation) -> list[dict[str, Any]]:
    """One row per bin of every trial (for a CSV): trial, t_s, positive, negative, net,
    net_smoothed, action (annotated, "" when none) and action_detected (when segmented)."""
    rows = []
    for acc in run.trials:
        c = acc.counts
        truth = acc.true_labels
        detected = (acc.segmentation.labels if acc.segmentation is not None
                    and acc.segmentation.status != "failed" else None)
        for k in range(c.n_bins):
            row: dict[str, Any] = {
                "trial": acc.trial, "t_s": round(float(c.t_s[k]), 9),
                "positive": int(c.positive[k]), "negative": int(c.negative[k]),
                "net": int(c.net[k]), "net_smoothed": round(float(acc.smoothed[k]), 6),
                "action": ACTIONS[truth[k]] if truth is not None and truth[k] >= 0 else "",
            }
            if run.segmented:
                row["action_detected"] = (ACTIONS[detected[k]] if detected is not None
                                          and detected[k] >= 0 else "")
            rows.append(row)
    return rows


def write_bins_csv(run: FileAccumulation, out: str | Path, *, overwrite: bool = False) -> Path:
    """Write :func:`bin_rows` to a CSV file (temporary file, then an atomic rename)."""
    out = check_output_file(out, overwrite=overwrite)
    rows = bin_rows(run)
    fields = ["trial", "t_s", "positive", "negative", "net", "net_smoothed", "action"]
    if run.segmented:
        fields.append("action_detected")
    with atomic_file(out, overwrite=overwrite) as tmp, \
            open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=fields, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return out


__all__ = ["STREAM", "FileAccumulation", "TrialAccumulation", "accumulate_file", "bin_rows",
           "write_bins_csv", "write_counts"]

