"""Will the figure hold on later recordings? Input shift and interleaving (issue 34, item 1).

A cross-validation that holds out trials recorded between training trials measures
accuracy on the training session, not on the next one. ``tactile evaluate`` says two
things about the evaluated trials beside its metrics (metrics.json keys ``shift`` and
``interleaving``):

- **Input shift** (:func:`input_shift`): per channel, the mean of the evaluated samples as
  the model receives them (after the run's baseline removal and transform, before the
  standardisation) minus the training split's mean, in training standard deviations, and
  the ratio of their standard deviations. A channel whose ``|shift_sd|`` exceeds the
  threshold (default :data:`SHIFT_THRESHOLD_SD`) is flagged: the model sees levels it was
  not trained on.
- **Interleaving** (:func:`interleaving`): whether evaluated trials lie inside the
  recording span of the trials the run learned from (its train and val splits). Recording
  order is the trials' start time (attribute ``time_origin_unix_s``) when every trial has
  one, else the label a ``blocked`` split ordered by. :func:`recording_record` stores the
  training span in ``run.json`` (key ``recording_order``), overall and per class of the
  trial-level target, so that the check also works on data files the run never saw.
  A trial counts as inside when its order value lies between the earliest and the latest
  training trial of its class, bounds included (overall when the run has no trial-level
  class); one such trial makes the evaluation ``interleaved``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..natural import natural_key
from .config import DataConfig
from .data import Normalisation, TrialSeries, transform_samples, trial_samples
from .heads import HeadSpec
from .splits import TIME_ORIGIN

#: Default flag threshold of the input shift, in training standard deviations.
SHIFT_THRESHOLD_SD = 1.0


@dataclass(frozen=True)
class ChannelShift:
    """One channel: ``shift_sd`` = (evaluated mean - training mean) / training std;
    ``spread_ratio`` = evaluated std / training std; ``flagged``: ``|shift_sd|`` above the
    threshold."""

    channel: str
    shift_sd: float
    spread_ratio: float
    flagged: bool


@dataclass
class ShiftReport:
    """The input shift of evaluated data against a run's training split (per channel)."""

    threshold_sd: float
    n_samples: int
    channels: list[ChannelShift]
    basis: str = ("samples after the run's baseline removal and transform, against the "
                  "training split's per-channel mean and standard deviation")
    folds: list[dict[str, Any]] | None = None
    """Cross-validated runs: each fold's held-out trials against that fold's training
    split; ``channels`` then holds, per channel, the fold with the largest ``|shift_sd|``."""

    @property
    def flagged(self) -> list[ChannelShift]:
        return [c for c in self.channels if c.flagged]

    @property
    def max_abs_shift_sd(self) -> float:
        values = [abs(c.shift_sd) for c in self.channels if math.isfinite(c.shift_sd)]
        return max(values) if values else math.nan

    def as_dict(self) -> dict[str, Any]:
        return {"threshold_sd": self.threshold_sd, "n_samples": self.n_samples,
                "basis": self.basis, "max_abs_shift_sd": self.max_abs_shift_sd,
                "flagged": [c.channel for c in self.flagged],
                "channels": [asdict(c) for c in self.channels],
                **({"folds": self.folds} if self.folds is not None else {})}

    def summary(self, top: int = 4) -> str:
        """``"2 of 22 channels shifted beyond 1 training SD: ele5 +1.42, pdc -1.10"``."""
        worst = sorted(self.flagged, key=lambda c: -abs(c.shift_sd))[:top]
        listed = ", ".join(f"{c.channel} {c.shift_sd:+.2f}" for c in worst)
        more = f" (and {len(self.flagged) - top} more)" if len(self.flagged) > top else ""
        return (f"{len(self.flagged)} of {len(self.channels)} channel(s) shifted beyond "
                f"{self.threshold_sd:g} training SD from the training data"
                + (f": {listed}{more}" if listed else ""))


def shift_stats(trials: Sequence[TrialSeries], data: DataConfig, norm: Normalisation
                ) -> tuple[np.ndarray, np.ndarray, int]:
    """(c,) mean and (c,) std of the evaluated samples as the run transforms them (baseline
    removal, transform), accumulated trial by trial in float64, and the sample count."""
    c = len(norm.channels)
    total, squares, n = np.zeros(c), np.zeros(c), 0
    for t in trials:
        y = transform_samples(trial_samples(t, data.baseline), norm.transform)
        total += y.sum(axis=0)
        squares += (y**2).sum(axis=0)
        n += y.shape[0]
    if n == 0:
        return np.full(c, np.nan), np.full(c, np.nan), 0
    mean = total / n
    return mean, np.sqrt(np.maximum(squares / n - mean**2, 0.0)), n


def input_shift(trials: Sequence[TrialSeries], data: DataConfig, norm: Normalisation, *,
                threshold_sd: float = SHIFT_THRESHOLD_SD) -> ShiftReport:
    """Per-channel shift of ``trials`` against the training statistics ``norm`` (see the
    module docstring); ``data``: the run's data config (its baseline removal)."""
    mean, std, n = shift_stats(trials, data, norm)
    ref_std = np.where(np.asarray(norm.std) > 0, norm.std, 1.0)
    shift = (mean - np.asarray(norm.mean)) / ref_std
    ratio = std / ref_std
    channels = [ChannelShift(str(name), float(s), float(r),
                             bool(math.isfinite(s) and abs(s) > threshold_sd))
                for name, s, r in zip(norm.channels, shift, ratio, strict=True)]
    return ShiftReport(float(threshold_sd), n, channels)


def pooled_shift(reports: Sequence[ShiftReport], fold_ids: Sequence[int]) -> ShiftReport:
    """One report for the folds of a cross-validation: per channel the fold with the
    largest ``|shift_sd|``; every fold's channels under ``folds``."""
    if not reports:
        raise ValueError("`reports` is empty")
    threshold = reports[0].threshold_sd
    channels = []
    for j, ch in enumerate(reports[0].channels):
        worst = max((r.channels[j] for r in reports),
                    key=lambda c: abs(c.shift_sd) if math.isfinite(c.shift_sd) else -1.0)
        channels.append(ChannelShift(ch.channel, worst.shift_sd, worst.spread_ratio,
                                     worst.flagged))
    folds = [{"fold": int(f), "max_abs_shift_sd": r.max_abs_shift_sd,
              "flagged": [c.channel for c in r.flagged],
              "shift_sd": {c.channel: c.shift_sd for c in r.channels}}
             for f, r in zip(fold_ids, reports, strict=True)]
    return ShiftReport(threshold, sum(r.n_samples for r in reports), channels,
                       basis=reports[0].basis + "; per channel the fold with the largest "
                       "shift", folds=folds)


# -- recording order ---------------------------------------------------------------------------
def class_head(heads: Sequence[HeadSpec]) -> HeadSpec | None:
    """The first trial-level classification head (whose classes the spans are kept by)."""
    return next((h for h in heads if h.kind == "classification" and h.source == "trial"),
                None)


def _order_values(trials: Sequence[TrialSeries], by: str) -> list[str] | None:
    """Each trial's place in recording order as text (natural order), or None when one
    trial has no value."""
    out = []
    for t in trials:
        if by in t.trial_labels:
            out.append(str(t.trial_labels[by]))
        elif by == TIME_ORIGIN and t.time_origin_unix_s is not None:
            out.append(repr(float(t.time_origin_unix_s)))
        else:
            return None
    return out


def order_label(trials: Sequence[TrialSeries], split_mode: str, split_by: str | None
                ) -> str | None:
    """What gives these trials' recording order: ``time_origin_unix_s`` when every trial
    has a start time, else the label of a ``blocked`` split; None when neither."""
    if trials and all(t.time_origin_unix_s is not None for t in trials):
        return TIME_ORIGIN
    if split_mode == "blocked" and split_by is not None and \
            _order_values(trials, split_by) is not None:
        return split_by
    return None


def _span(values: Sequence[str]) -> list[str]:
    ordered = sorted(values, key=natural_key)
    return [ordered[0], ordered[-1]]


def recording_record(trials: Sequence[TrialSeries], heads: Sequence[HeadSpec], *,
                     split_mode: str, split_by: str | None) -> dict[str, Any] | None:
    """``run.json`` key ``recording_order``: the span (earliest, latest, as text in
    natural order) of the trials a run learned from, overall and per class of its
    trial-level classification head; None when their order is unknown."""
    by = order_label(trials, split_mode, split_by)
    values = _order_values(trials, by) if by is not None else None
    if by is None or values is None or not trials:
        return None
    head = class_head(heads)
    classes: dict[str, list[str]] = {}
    if head is not None:
        for t, v in zip(trials, values, strict=True):
            classes.setdefault(str(t.trial_labels.get(head.name, "")), []).append(v)
    return {"by": by, "n_trials": len(trials), "span": _span(values),
            "class_label": None if head is None else head.name,
            "class_spans": {c: _span(v) for c, v in classes.items()}}


@dataclass
class Interleaving:
    """How many evaluated trials lie inside the recording span of the training trials."""

    order_by: str | None
    n_evaluated: int
    n_inside_span: int | None = None
    class_label: str | None = None
    n_inside_class_span: int | None = None
    interleaved: bool | None = None
    reason: str | None = None
    folds: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        if not self.folds:
            out.pop("folds")
        return out

    def message(self) -> str | None:
        """The one-line warning when interleaved, else None."""
        if not self.interleaved:
            return None
        inside = self.n_inside_class_span if self.n_inside_class_span is not None \
            else self.n_inside_span
        where = f" of their {self.class_label}" if self.n_inside_class_span is not None else ""
        return (f"{inside} of {self.n_evaluated} evaluated trial(s) lie inside the recording "
                f"span (by {self.order_by}) of the training trials{where}: held-out trials "
                "interleaved in time with training ones overstate accuracy on later "
                "recordings; hold out whole blocks in recording order (data.split: {mode: "
                "blocked, by: ...})")


def _inside(value: str, span: Sequence[str]) -> bool:
    key = natural_key(value)
    return natural_key(span[0]) <= key <= natural_key(span[1])


def interleaving(trials: Sequence[TrialSeries], record: Mapping[str, Any] | None
                 ) -> Interleaving:
    """Where ``trials`` lie against a run's ``recording_order`` record (module docstring)."""
    if record is None:
        return Interleaving(None, len(trials), reason="the run records no recording order "
                            "(its trials had no start time and it was not split by a "
                            "recording-order label)")
    by = str(record["by"])
    values = _order_values(trials, by)
    if values is None:
        return Interleaving(by, len(trials), reason=f"an evaluated trial has no {by}")
    inside = sum(_inside(v, record["span"]) for v in values)
    label = record.get("class_label")
    spans = record.get("class_spans") or {}
    inside_class = None
    if label is not None:
        inside_class = sum(
            str(t.trial_labels.get(label, "")) in spans
            and _inside(v, spans[str(t.trial_labels.get(label, ""))])
            for t, v in zip(trials, values, strict=True))
    decisive = inside_class if inside_class is not None else inside
    return Interleaving(by, len(trials), inside, label, inside_class, decisive > 0)


def pooled_interleaving(parts: Sequence[Interleaving], fold_ids: Sequence[int]
                        ) -> Interleaving:
    """The folds' interleaving checks summed (each fold's held-out trials against its own
    training span); unknown when any fold's is."""
    folds = [{"fold": int(f), **{k: v for k, v in p.as_dict().items() if k != "folds"}}
             for f, p in zip(fold_ids, parts, strict=True)]
    n = sum(p.n_evaluated for p in parts)
    unknown = next((p for p in parts if p.interleaved is None), None)
    if unknown is not None or not parts:
        return Interleaving(unknown.order_by if unknown else None, n,
                            reason=unknown.reason if unknown else "no folds", folds=folds)
    by_class = all(p.n_inside_class_span is not None for p in parts)
    return Interleaving(
        parts[0].order_by, n, sum(p.n_inside_span or 0 for p in parts),
        parts[0].class_label if by_class else None,
        sum(p.n_inside_class_span or 0 for p in parts) if by_class else None,
        any(p.interleaved for p in parts), folds=folds)


__all__ = ["SHIFT_THRESHOLD_SD", "ChannelShift", "Interleaving", "ShiftReport", "class_head",
           "input_shift", "interleaving", "order_label", "pooled_interleaving",
           "pooled_shift", "recording_record", "shift_stats"]
