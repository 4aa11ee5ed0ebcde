"""What ``tactile evaluate`` computes and writes, for one run or the pooled folds of a
cross-validated one: Table I metrics per head, intervals and per-trial votes, the
metrics.json record and the evaluation folder (see :mod:`.evaluate` for the command's
library function and the folder layout).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import InputError
from ..store.outdir import check_output_folder
from ..store.provenance import sha256_of
from ..store.reader import recording_hashes
from . import runs
from .data import WindowSet
from .figures import plot_confusion
from .heads import HeadSpec
from .latency import LatencyStats, measure_latency
from .trial_metrics import bootstrap_window_intervals, per_trial_confusion, trial_votes


@dataclass(frozen=True)
class ClassMetrics:
    """One row of Table I. ``absent``: the class has no support in the evaluated data (its
    recall and F1 mean nothing and it is left out of the macro average)."""

    name: str
    precision: float
    recall: float
    f1: float
    support: int
    absent: bool = False


@dataclass
class ClassificationMetrics:
    """Table I of paper 000 for one head, plus the confusion matrix (rows: true class,
    columns: predicted class; it sums to ``n``)."""

    head: str
    classes: list[str]
    n: int
    accuracy: float
    macro_f1: float
    per_class: list[ClassMetrics]
    confusion_matrix: list[list[int]]
    boundary_margin: int | None = None
    n_near_boundary: int | None = None
    accuracy_excluding_boundaries: float | None = None
    kind: str = "classification"
    warnings: list[str] = field(default_factory=list)
    """Zero-support classes left out of the macro F1; a macro F1 over one present class."""
    accuracy_ci95: list[float] | None = None
    macro_f1_ci95: list[float] | None = None
    """95 % bootstrap intervals over trials (:mod:`.trial_metrics`); None with < 2 trials."""
    n_trials: int | None = None
    per_trial: dict[str, Any] | None = None
    """Trial-level targets: :class:`.trial_metrics.TrialVotes` as a dict."""
    per_group: dict[str, Any] | None = None
    """Trial-level targets with ``data.decide_by``: the votes of each group of trials that
    share that label (:class:`.trial_metrics.TrialVotes` as a dict, ``n_trials`` counting
    groups) and ``by``, the label."""
    accuracy_by: dict[str, dict[str, dict[str, Any]]] | None = None
    """Multi-task runs: this head's accuracy within each true class of every other
    classification head, ``{other head: {class: {"accuracy", "n"}}}`` (e.g. texture at
    rest, while sliding and while slipping; paper 001, sec. 6.2). None with one head."""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class RegressionMetrics:
    """Mean absolute and root-mean-square error in the label's units."""

    head: str
    n: int
    mae: float
    rmse: float
    kind: str = "regression"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def classification_metrics(y_true: np.ndarray, y_pred: np.ndarray, classes: Sequence[str], *,
                           head: str = "", near_boundary: np.ndarray | None = None,
                           boundary_margin: int | None = None) -> ClassificationMetrics:
    """Accuracy, per-class P/R/F1 and confusion matrix of class indices (n,) each.

    A class never predicted has precision 0. A class never present (zero support) is
    flagged ``absent``, left out of the macro F1 and named in ``warnings``; a macro F1 over
    a single present class carries a warning too (it says nothing about the others)."""
    k = len(classes)
    y_true = np.asarray(y_true, dtype=np.int64)
    y_pred = np.asarray(y_pred, dtype=np.int64)
    cm = np.bincount(y_true * k + y_pred, minlength=k * k).reshape(k, k)
    tp = np.diag(cm).astype(np.float64)
    predicted, actual = cm.sum(axis=0), cm.sum(axis=1)
    precision = np.divide(tp, predicted, out=np.zeros(k), where=predicted > 0)
    recall = np.divide(tp, actual, out=np.zeros(k), where=actual > 0)
    denom = precision + recall
    f1 = np.divide(2 * precision * recall, denom, out=np.zeros(k), where=denom > 0)
    n = int(y_true.shape[0])
    per_class = [ClassMetrics(str(c), float(precision[i]), float(recall[i]), float(f1[i]),
                              int(actual[i]), bool(actual[i] == 0))
                 for i, c in enumerate(classes)]
    warnings = support_warnings(head, [str(c) for c in classes], actual)
    out = ClassificationMetrics(
        head=head, classes=[str(c) for c in classes], n=n,
        accuracy=float(tp.sum() / n) if n else math.nan,
        macro_f1=float(f1[actual > 0].mean()) if (actual > 0).any() else math.nan,
        per_class=per_class, confusion_matrix=cm.tolist(), warnings=warnings)
    if near_boundary is not None:
        keep = ~np.asarray(near_boundary, dtype=bool)
        out.boundary_margin = boundary_margin
        out.n_near_boundary = int((~keep).sum())
        out.accuracy_excluding_boundaries = (
            float((y_true[keep] == y_pred[keep]).mean()) if keep.any() else math.nan)
    return out


def support_warnings(head: str, classes: Sequence[str], support: np.ndarray) -> list[str]:
    """Warnings for classes without support and for a single present class."""
    if not len(support) or support.sum() == 0:
        return [f"{head}: no labelled window in the evaluated data"]
    absent = [c for c, n in zip(classes, support, strict=True) if n == 0]
    out = []
    if absent:
        out.append(f"{head}: class(es) {', '.join(absent)} have no support in the evaluated "
                   "data: their recall and F1 mean nothing and they are left out of the macro "
                   "F1")
    present = [c for c, n in zip(classes, support, strict=True) if n > 0]
    if len(present) == 1:
        out.append(f"{head}: only class {present[0]} is present: accuracy and macro F1 say "
                   "nothing about telling the classes apart")
    return out


def regression_metrics(y_true: np.ndarray, y_pred: np.ndarray, *, head: str = ""
                       ) -> RegressionMetrics:
    err = np.asarray(y_pred, dtype=np.float64) - np.asarray(y_true, dtype=np.float64)
    n = int(err.shape[0])
    return RegressionMetrics(head, n, float(np.abs(err).mean()) if n else math.nan,
                             float(np.sqrt((err**2).mean())) if n else math.nan)


@dataclass
class EvalResult:
    """Everything ``tactile evaluate`` reports (``as_dict`` is metrics.json)."""

    run: str
    family: str
    name: str
    split: str
    data: list[dict[str, Any]]
    overlaps_training: list[str]
    n_trials: int
    n_windows: int
    heads: list[ClassificationMetrics | RegressionMetrics]
    n_params: int
    size_mb: float
    file_size_bytes: int
    latency: LatencyStats | None
    out_dir: Path
    command: str = ""
    created_utc: str = ""
    extra: dict[str, Any] = field(default_factory=dict)
    input: dict[str, Any] | None = None
    """The data's stream, sample period, channels and units, and whether they were checked
    against the run's (:func:`.inputs.input_record`)."""
    notes: list[str] = field(default_factory=list)
    cv: dict[str, Any] | None = None
    """Cross-validated runs: folds, per-fold results, their mean and spread."""
    origin: dict[str, Any] | None = None
    """Where the data come from (recorded, simulated, synthetic; :mod:`..store.origin`)."""

    @property
    def warnings(self) -> list[str]:
        """Every head's warnings (zero support, one present class) and the CV plan's."""
        out = list((self.cv or {}).get("warnings", []))
        for h in self.heads:
            out += getattr(h, "warnings", [])
        return out

    @property
    def accuracy(self) -> float | None:
        """Accuracy of the primary (first classification) head."""
        return next((h.accuracy for h in self.heads
                     if isinstance(h, ClassificationMetrics)), None)

    def as_dict(self) -> dict[str, Any]:
        primary = next((h for h in self.heads if isinstance(h, ClassificationMetrics)), None)
        return {
            "format": runs.EVAL_FORMAT, "format_version": runs.EVAL_FORMAT_VERSION,
            "tool_version": __version__, "created_utc": self.created_utc,
            "command": self.command, "run": self.run, "family": self.family,
            "name": self.name, "split": self.split, "data": self.data,
            "overlaps_training": self.overlaps_training,
            "n_trials": self.n_trials, "n_windows": self.n_windows,
            "primary_head": None if primary is None else primary.head,
            "accuracy": self.accuracy,
            "accuracy_excluding_boundaries": None if primary is None
            else primary.accuracy_excluding_boundaries,
            "heads": {h.head: h.as_dict() for h in self.heads},
            "latency": None if self.latency is None else self.latency.as_dict(),
            "model": {"n_params": self.n_params, "size_mb": self.size_mb,
                      "file_size_bytes": self.file_size_bytes},
            "input": self.input, "notes": list(self.notes), "warnings": self.warnings,
            **({"cv": self.cv} if self.cv is not None else {}),
            "origin": self.origin,
            **self.extra,
        }


def head_metrics(heads: Sequence[HeadSpec], outputs: dict[str, np.ndarray], ws: WindowSet,
                 targets_scale: dict[str, tuple[float, float]], boundary_margin: int,
                 groups: tuple[str, Sequence[str]] | None = None
                 ) -> tuple[list[ClassificationMetrics | RegressionMetrics],
                            dict[str, np.ndarray]]:
    """Metrics of every head and the decoded predictions (class index or value).
    ``groups``: ``(label, value of every trial of ws.trials)`` to also decide trial-level
    targets per group of trials (``data.decide_by``; :func:`.data.trial_groups`).

    Classification heads also get bootstrap intervals over trials and, for trial-level
    targets, per-trial majority-vote and mean-probability results; the accuracy without
    windows near a label change only where some trial's labels change inside the trial."""
    metrics: list[ClassificationMetrics | RegressionMetrics] = []
    decoded: dict[str, np.ndarray] = {}
    n_trials = len(ws.trials)
    for head in heads:
        out = outputs[head.name]
        if head.kind == "classification":
            pred = out.argmax(axis=1)
            decoded[head.name] = pred
            changes = ws.label_changes.get(head.name, False)
            m = classification_metrics(
                ws.targets[head.name], pred, head.classes, head=head.name,
                near_boundary=ws.near_boundary.get(head.name) if changes else None,
                boundary_margin=boundary_margin if changes else None)
            cms = per_trial_confusion(ws.targets[head.name], pred, ws.trial_index, n_trials,
                                      len(head.classes))
            cms = cms[cms.sum(axis=(1, 2)) > 0]
            m.n_trials = int(cms.shape[0])
            ci = bootstrap_window_intervals(cms)
            m.accuracy_ci95, m.macro_f1_ci95 = ci["accuracy_ci95"], ci["macro_f1_ci95"]
            if head.source == "trial":
                votes = trial_votes(ws.targets[head.name], out, ws.trial_index)
                m.per_trial = None if votes is None else votes.as_dict()
                if groups is not None and len(ws):
                    by, values = groups
                    _, inverse = np.unique(np.asarray(values, dtype=object).astype(str),
                                           return_inverse=True)
                    pooled = trial_votes(ws.targets[head.name], out, inverse[ws.trial_index])
                    m.per_group = None if pooled is None else {"by": by, **pooled.as_dict()}
            metrics.append(m)
        else:
            m_, s_ = targets_scale.get(head.name, (0.0, 1.0))
            pred = out.astype(np.float64) * s_ + m_
            true = ws.targets[head.name].astype(np.float64) * s_ + m_
            decoded[head.name] = pred
            metrics.append(regression_metrics(true, pred, head=head.name))
    _accuracy_by_other_heads(heads, metrics, decoded, ws)
    return metrics, decoded


def accuracy_within(y_true: np.ndarray, y_pred: np.ndarray, group: np.ndarray,
                    group_classes: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Accuracy of ``y_pred`` (n,) against ``y_true`` (n,) within each ``group`` (n,)
    class index: ``{class: {"accuracy": float | None, "n": int}}`` (None: no window;
    negative group indices, unlabelled windows, are left out)."""
    out: dict[str, dict[str, Any]] = {}
    hit = np.asarray(y_true) == np.asarray(y_pred)
    for i, name in enumerate(group_classes):
        mask = np.asarray(group) == i
        n = int(mask.sum())
        out[str(name)] = {"accuracy": float(hit[mask].mean()) if n else None, "n": n}
    return out


def _accuracy_by_other_heads(heads: Sequence[HeadSpec],
                             metrics: Sequence[ClassificationMetrics | RegressionMetrics],
                             decoded: dict[str, np.ndarray], ws: WindowSet) -> None:
    classifiers = [(h, m) for h, m in zip(heads, metrics, strict=True)
                   if isinstance(m, ClassificationMetrics)]
    if len(classifiers) < 2:
        return
    for head, m in classifiers:
        m.accuracy_by = {
            other.name: accuracy_within(ws.targets[head.name], decoded[head.name],
                                        ws.targets[other.name], other.classes)
            for other, _ in classifiers if other.name != head.name}


def check_eval_folder(run_path: Path, name: str, overwrite: bool) -> Path:
    """``RUN/eval/<name>``, after refusing an existing one (without ``overwrite``) and a
    file where a folder must go, before any work."""
    out_dir = run_path / runs.EVAL_DIR / name
    if out_dir.is_dir() and not overwrite:
        raise InputError("evaluation folder exists; pass `overwrite=True` to replace it "
                         "or give another `name`", path=out_dir)
    check_output_folder(out_dir, overwrite=True)
    return out_dir


def measure_latency_of(model: Any, ws: WindowSet, threads: int | None) -> LatencyStats:
    """Batch-1 latency and throughput on up to 2,048 windows of ``ws`` (seeded pick)."""
    rng = np.random.default_rng(0)
    pick = rng.choice(len(ws), size=min(len(ws), 2048), replace=False)
    return measure_latency(model, ws.windows(np.sort(pick)), threads=threads)


def data_records(paths: Sequence[Path], trials: Sequence[Any]) -> list[dict[str, Any]]:
    """Per data file: path, SHA-256, the recordings' hashes and the trials evaluated."""
    return [{"path": str(p), "sha256": h, "recordings_sha256": recording_hashes(p, h),
             "n_trials": sum(1 for t in trials if t.file == str(p))}
            for p, h in ((p, sha256_of(p)) for p in paths)]


def overlaps(paths: Sequence[Path], info: dict[str, Any]) -> list[str]:
    """The data files the run was trained on (same SHA-256)."""
    trained_on = {d.get("sha256") for d in info.get("data", []) if isinstance(d, dict)}
    return [str(p) for p in paths if sha256_of(p) in trained_on]


def write_eval(result: EvalResult, heads: Sequence[HeadSpec], ws: WindowSet,
               decoded: dict[str, np.ndarray], scale: dict[str, tuple[float, float]], *,
               overwrite: bool = False) -> None:
    """Write ``result.out_dir`` atomically: metrics.json, confusion matrices (PNG, JSON)
    and predictions.csv (one row per window)."""
    def fill(tmp: Path) -> None:
        runs.write_json(tmp / runs.METRICS_JSON, result.as_dict())
        for m in result.heads:
            if isinstance(m, ClassificationMetrics):
                cm = np.asarray(m.confusion_matrix)
                plot_confusion(cm, m.classes, tmp / f"confusion_{m.head}.png",
                               title=f"{result.family} {m.head}: accuracy "
                                     f"{100 * m.accuracy:.2f} % ({m.n:,} windows)")
                (tmp / f"confusion_{m.head}.json").write_text(json.dumps(
                    {"head": m.head, "classes": m.classes, "rows": "true", "columns": "predicted",
                     "matrix": m.confusion_matrix}, indent=2) + "\n", encoding="utf-8")
        with open(tmp / runs.PREDICTIONS_CSV, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            cols = ["trial", "end_index", "target_index", "target_t_s"]
            for h in heads:
                cols += [f"{h.name}_true", f"{h.name}_pred"]
            w.writerow(cols)
            trial_keys = np.asarray(ws.trials, dtype=object)[ws.trial_index]
            columns: list[np.ndarray] = [trial_keys, ws.end_index, ws.target_index,
                                         np.round(ws.target_t_s, 6)]
            for h in heads:
                if h.kind == "classification":
                    classes = np.asarray(h.classes, dtype=object)
                    columns += [classes[ws.targets[h.name]], classes[decoded[h.name]]]
                else:
                    m, s = scale.get(h.name, (0.0, 1.0))
                    columns += [ws.targets[h.name].astype(np.float64) * s + m, decoded[h.name]]
            w.writerows(zip(*columns, strict=True))

    runs.write_folder(result.out_dir, fill, overwrite=overwrite)


__all__ = ["ClassMetrics", "ClassificationMetrics", "EvalResult", "RegressionMetrics",
           "check_eval_folder", "classification_metrics", "data_records", "head_metrics",
           "measure_latency_of", "overlaps", "regression_metrics", "support_warnings",
           "write_eval"]
