"""``tactile compare``: accuracy against cost of several runs, and the model a scene needs.

Issue 4, item 5. Each run's ``RUN/eval/<name>/metrics.json`` (written by ``tactile
evaluate``, see :mod:`.evaluate`) gives its score on one evaluation data set and its cost
on this machine. The runs must have been evaluated on the same recordings (the same files
by SHA-256, or files derived from them such as ``tactile centroids`` streams, with the same
trials and split); :func:`compare` refuses to put other numbers side by side. Each
evaluation must also have been of data of its run's input (:mod:`.inputs`): a metrics.json
whose recorded ``input`` has a sample period more than 0.5 % from the ``input`` of the
run's run.json, or other channels or units, is refused; where either file predates that
record the comparison goes ahead with a note saying what was not checked.

What is compared:

* the score: overall accuracy of the primary head (default), its macro F1
  (``metric="macro_f1"``) or the F1 of one class (``metric="f1:slip"``), as a fraction;
* the cost a real-time user pays: latency per window at batch 1, median (ms).

The Pareto front holds the runs no other run dominates; run *s* dominates run *r* when
``score_s >= score_r`` and ``latency_s <= latency_r`` with at least one of them strict
(lower latency and higher score are better; exact ties are both on the front).

"The model this scene needs" (the issue's "model no more than a scene needs"): among the
runs whose score is within ``margin_pp`` percentage points of the best, the one with the
fewest parameters, ties broken by lower latency then by label. The fastest run within the
margin (lowest batch-1 latency, ties by fewer parameters) is named beside it. With
``targets`` (``{"motion": 0.948, "object": 0.96, "speed_cm_s": 3.4}``: an accuracy, as a
fraction, that a classification head must reach, or an MAE, in the label's units, that a
regression head must not exceed) the eligible runs are those meeting every target instead
of those within the margin, and when none does the comparison says so.

A ``tactile seed-spread`` folder may stand for a run (:func:`spread_runs`): its point is
the mean over its seeds (:func:`spread_point`; the cost is the first seed's, which the
spread times alone), the table gives the seeds' SD, and the notes say where that SD is
larger than the margin or than the gap the choice rests on (:func:`seed_notes`).

Outputs (:func:`write_comparison`): ``compare.png`` (the chart), ``compare.csv`` (the
table) and ``compare.json`` (the table, the choice and the provenance: command, tool
version, the metrics files read with their SHA-256), each written atomically.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import InputError
from ..store.atomic import write_bytes, write_text
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .inputs import InputSpec, mismatch

COMPARE_PNG = "compare.png"
COMPARE_CSV = "compare.csv"
COMPARE_JSON = "compare.json"
COMPARE_FORMAT = "tactile-compare"
COMPARE_FORMAT_VERSION = 1


# -- pure selection --------------------------------------------------------------------------
def pareto_front(score: np.ndarray, latency_ms: np.ndarray) -> np.ndarray:
    """(n,) bool: the points no other point dominates (higher score and lower latency are
    better; see the module docstring). NaN latency or score: never on the front and
    dominating nothing."""
    s = np.asarray(score, dtype=np.float64)
    lat = np.asarray(latency_ms, dtype=np.float64)
    if s.shape != lat.shape or s.ndim != 1:
        raise ValueError(f"`score` {s.shape} and `latency_ms` {lat.shape} must be equal 1-D")
    ok = np.isfinite(s) & np.isfinite(lat)
    ge = s[:, None] >= s[None, :]  # [j, i]: j scores at least as high as i
    le = lat[:, None] <= lat[None, :]
    strict = (s[:, None] > s[None, :]) | (lat[:, None] < lat[None, :])
    dominates = ge & le & strict & ok[:, None] & ok[None, :]
    return ok & ~dominates.any(axis=0)


def within_margin(score: np.ndarray, margin_pp: float) -> np.ndarray:
    """(n,) bool: score (fraction) within ``margin_pp`` percentage points of the best.
    A tolerance of 1e-9 keeps a run exactly at the margin inside it."""
    if not margin_pp >= 0:
        raise ValueError(f"`margin_pp` (={margin_pp}) must be >= 0")
    s = np.asarray(score, dtype=np.float64)
    if not np.isfinite(s).any():
        return np.zeros(s.shape, dtype=bool)
    best = np.nanmax(s)
    return np.isfinite(s) & (s >= best - margin_pp / 100.0 - 1e-9)


def pick_needed(n_params: np.ndarray, latency_ms: np.ndarray, eligible: np.ndarray,
                labels: Sequence[str]) -> int:
    """Index of the eligible point with the fewest parameters (ties: lower latency, a
    missing latency counting as slowest, then label)."""
    idx = np.flatnonzero(eligible)
    if idx.size == 0:
        raise ValueError("no eligible point")
    lat = np.where(np.isfinite(latency_ms), latency_ms, np.inf)
    return int(min(idx, key=lambda i: (int(n_params[i]), float(lat[i]), labels[i])))


def pick_fastest(n_params: np.ndarray, latency_ms: np.ndarray, eligible: np.ndarray,
                 labels: Sequence[str]) -> int | None:
    """Index of the eligible point with the lowest latency (ties: fewer parameters, then
    label); None when no eligible point has a latency."""
    idx = [i for i in np.flatnonzero(eligible) if np.isfinite(latency_ms[i])]
    if not idx:
        return None
    return int(min(idx, key=lambda i: (float(latency_ms[i]), int(n_params[i]), labels[i])))


# -- reading runs ----------------------------------------------------------------------------
@dataclass
class RunPoint:
    """One run's evaluation: score, cost and where they came from.

    score, accuracy, macro_f1: fractions (0..1) of the primary head; latency_ms,
    latency_p95_ms: per window at batch 1 (median, 95th percentile) on the machine that
    ran ``tactile evaluate``; windows_per_s at its large batch; size_mb of the state dict.
    """

    run: str
    label: str
    family: str
    eval_name: str
    metrics_path: str
    score: float
    accuracy: float | None
    macro_f1: float | None
    latency_ms: float | None
    latency_p95_ms: float | None
    windows_per_s: float | None
    n_params: int
    size_mb: float
    n_windows: int
    split: str
    primary_head: str
    data: list[dict[str, Any]] = field(default_factory=list)
    latency_threads: int | None = None
    cpu: str = ""
    pareto: bool = False
    within_margin: bool = False
    input: dict[str, Any] | None = None  # metrics.json ``input``: the evaluation data's
    score_ci95: list[float] | None = None
    """95 % bootstrap interval over trials of ``score`` (fractions) where the evaluation
    has one (cross-validated runs: accuracy, macro F1, per-trial accuracy), else None."""
    head_values: dict[str, float | None] = field(default_factory=dict)
    """Every head's accuracy (classification, fraction) or MAE (regression, label units)."""
    head_kinds: dict[str, str] = field(default_factory=dict)
    meets_targets: bool | None = None
    """Whether every target of the comparison is met (None: no targets)."""
    exported_latency_ms: float | None = None
    """Batch-1 median latency (ms) of the run's exported model (``tactile evaluate
    --exported``) where measured: the deployed cost beside torch's ``latency_ms``."""
    exported_runtime: str = ""
    seeds: dict[str, Any] | None = None
    """A `tactile seed-spread` folder given as one run: ``n``, the ``seeds``, each seed's
    ``scores`` and their ``sd`` (fractions; ddof 1), ``min`` and ``max``. Then ``score``,
    ``accuracy``, ``macro_f1`` and ``head_values`` are the means over the seeds, the cost
    and ``n_params`` are the first seed's, and ``score_ci95`` is None (an interval over
    trials of one seed is not one of the mean)."""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Comparison:
    """Runs on one evaluation data set side by side (see the module docstring)."""

    points: list[RunPoint]
    metric: str
    data_name: str
    margin_pp: float
    best: RunPoint
    needed: RunPoint | None  # None only when targets are given and no run meets them
    fastest: RunPoint | None
    pareto: list[RunPoint]  # on the front, by increasing latency
    inputs: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    targets: dict[str, float] = field(default_factory=dict)
    files: ComparisonFiles | None = None
    """compare.png, .csv and .json where :func:`compare_runs` wrote them."""

    def targets_text(self) -> str:
        """``motion >= 94.8 %, speed_cm_s MAE <= 3.4`` (empty without targets)."""
        return describe_targets(self.targets, self.points[0].head_kinds if self.points
                                else {})

    @property
    def metric_label(self) -> str:
        if self.metric == "accuracy":
            return "accuracy"
        if self.metric == "macro_f1":
            return "macro F1"
        if self.metric == "trial_accuracy":
            return "per-trial accuracy"
        if self.metric == "group_accuracy":
            return "per-group accuracy"
        return f"F1 of class {self.metric.split(':', 1)[1]!r}"

    def as_dict(self) -> dict[str, Any]:
        return {
            "metric": self.metric, "data_name": self.data_name, "margin_pp": self.margin_pp,
            "best": self.best.label,
            "needed": None if self.needed is None else self.needed.label,
            "targets": dict(self.targets),
            "fastest": None if self.fastest is None else self.fastest.label,
            "pareto": [p.label for p in self.pareto],
            "runs": [p.as_dict() for p in self.points], "notes": list(self.notes),
        }

    def summary(self) -> str:
        """Two sentences naming the model this scene needs and the fastest eligible one."""
        n = self.needed
        where = "the margin" if not self.targets else "the targets"
        if n is None:
            return (f"no run meets every target ({self.targets_text()}); best "
                    f"{self.metric_label}: {self.best.label} ({100 * self.best.score:.2f} %)")
        text = (f"the model this scene needs: {n.label} ({n.n_params:,} parameters, "
                f"{n.size_mb:.2f} MB, {self.metric_label} {100 * n.score:.2f} %, "
                f"{_ms(n.latency_ms)} per window), ")
        if self.targets:
            text += f"the smallest meeting {self.targets_text()}"
        else:
            text += (f"the smallest within {self.margin_pp:g} pp of the best "
                     f"({self.best.label}, {100 * self.best.score:.2f} %)")
        f = self.fastest
        if f is not None:
            text += (f"; fastest within {where}: {f.label} ({_ms(f.latency_ms)}, "
                     f"{f.n_params:,} parameters)")
        return text


def _ms(value: float | None) -> str:
    return "latency not measured" if value is None else f"{value:.3f} ms"


def eval_names(run_dir: Path) -> list[str]:
    """Names of the evaluations of a run that have a metrics.json, sorted."""
    d = run_dir / runs.EVAL_DIR
    if not d.is_dir():
        return []
    return sorted(p.name for p in d.iterdir()
                  if p.is_dir() and (p / runs.METRICS_JSON).is_file())


def check_run_folder(path: Path) -> Path:
    """``path`` if it is a run folder (has run.json), else an InputError saying so."""
    if path.is_file():
        raise InputError("is a file, not a run folder (give the folder `tactile train` "
                         "wrote)", path=path)
    if not path.is_dir():
        raise InputError("run folder not found (give the folder `tactile train` wrote)",
                         path=path)
    if not (path / runs.RUN_JSON).is_file():
        raise InputError("not a run folder (no run.json); train one with `tactile train`",
                         path=path)
    return path


def choose_data_name(run_dirs: Sequence[Path], data_name: str | None) -> str:
    """The evaluation every run has: ``data_name`` when given, else the one name all
    runs share (an error lists the names when there are none or several)."""
    names = {d: eval_names(d) for d in run_dirs}
    if data_name is not None:
        for d, have in names.items():
            if data_name not in have:
                raise InputError(
                    f"no evaluation named {data_name!r} (evaluations: "
                    f"{', '.join(have) or 'none'}); run `tactile evaluate {d} --data FILE` "
                    "on the same data as the other runs", path=d)
        return data_name
    for d, have in names.items():
        if not have:
            raise InputError("the run has no evaluation (no eval/<name>/metrics.json); run "
                             f"`tactile evaluate {d} --data FILE` first", path=d)
    common = sorted(set.intersection(*(set(v) for v in names.values())))
    if len(common) == 1:
        return common[0]
    if not common:
        listing = "; ".join(f"{d}: {', '.join(v)}" for d, v in names.items())
        raise InputError(f"the runs share no evaluation ({listing}); evaluate them on the "
                         "same data with `tactile evaluate RUN --data FILE`")
    raise InputError(f"the runs share several evaluations ({', '.join(common)}); choose one "
                     "with `data_name`")


def _score(metrics: dict[str, Any], metric: str, path: Path) -> float:
    head_name = metrics.get("primary_head")
    if head_name is None:
        raise InputError("the run has no classification head to compare (primary_head is "
                         "null)", path=path)
    head = metrics["heads"][head_name]
    if metric == "accuracy":
        value = head["accuracy"]
    elif metric == "macro_f1":
        value = head["macro_f1"]
    elif metric == "trial_accuracy":
        votes = head.get("per_trial")
        if not isinstance(votes, dict):
            raise InputError(f"head {head_name!r} has no per-trial result (only trial-level "
                             "targets are voted per trial); compare by accuracy", path=path)
        value = votes.get("majority_accuracy")
    elif metric == "group_accuracy":
        pooled = head.get("per_group")
        if not isinstance(pooled, dict):
            raise InputError(f"head {head_name!r} has no per-group result (a config's "
                             "`data.decide_by` label pools trials into groups, e.g. the "
                             "cameras of one experiment); compare by trial_accuracy",
                             path=path)
        value = pooled.get("majority_accuracy")
    elif metric.startswith("f1:"):
        cls = metric.split(":", 1)[1]
        found = [c for c in head["per_class"] if c["name"] == cls]
        if not found:
            raise InputError(f"`metric={metric!r}`: head {head_name!r} has no class {cls!r} "
                             f"(classes: {', '.join(c['name'] for c in head['per_class'])})",
                             path=path)
        value = found[0]["f1"]
    else:
        raise InputError("`metric` must be accuracy, macro_f1, trial_accuracy, "
                         f"group_accuracy or f1:<class>, got {metric!r}")
    if value is None or not math.isfinite(value):
        raise InputError(f"{metric} is not a number in this evaluation (no windows of the "
                         "class?)", path=path)
    return float(value)


def _score_ci(metrics: dict[str, Any], metric: str) -> list[float] | None:
    """The 95 % interval of the score where the evaluation records one, else None."""
    head = metrics["heads"][metrics["primary_head"]]
    if metric in ("accuracy", "macro_f1"):
        ci = head.get(f"{metric}_ci95")
    elif metric == "trial_accuracy":
        ci = (head.get("per_trial") or {}).get("majority_accuracy_ci95")
    elif metric == "group_accuracy":
        ci = (head.get("per_group") or {}).get("majority_accuracy_ci95")
    else:
        ci = None
    if (isinstance(ci, list) and len(ci) == 2
            and all(isinstance(v, int | float) and math.isfinite(v) for v in ci)):
        return [float(ci[0]), float(ci[1])]
    return None


def run_labels(run_dirs: Sequence[Path], families: Sequence[str]) -> list[str]:
    """``family/<folder name>``; ``family/<parent>/<folder>`` where folder names repeat."""
    names = [d.resolve().name for d in run_dirs]
    out = []
    for d, fam, name in zip(run_dirs, families, names, strict=True):
        if names.count(name) > 1:
            name = f"{d.resolve().parent.name}/{name}"
        out.append(f"{fam}/{name}")
    return out


def distinct_run_paths(run_dirs: Sequence[str | Path]) -> list[str]:
    """Each run folder relative to the common folder of all the runs' parents (its own name
    at least): ``sweep/lr0.003/lstm`` and ``sweep/lr0.01/lstm`` -> ``lr0.003/lstm``,
    ``lr0.01/lstm``; the part of each path that tells the runs apart."""
    paths = [Path(d).resolve() for d in run_dirs]
    if not paths:
        return []
    common = Path(os.path.commonpath([p.parent for p in paths]))
    return [p.relative_to(common).as_posix() for p in paths]


def describe_targets(targets: dict[str, float], kinds: dict[str, str]) -> str:
    """``motion >= 94.8 %, speed_cm_s MAE <= 3.4`` for targets of heads of these kinds."""
    return ", ".join(f"{h} >= {100 * v:g} %" if kinds.get(h) == "classification"
                     else f"{h} MAE <= {v:g}" for h, v in targets.items())


def meets_targets(values: dict[str, float | None], kinds: dict[str, str],
                  targets: dict[str, float]) -> bool:
    """True when every target is met: a classification head's accuracy (fraction) at least
    its target, a regression head's MAE at most its target; a missing value fails."""
    for head, target in targets.items():
        got = values.get(head)
        if got is None or not math.isfinite(got):
            return False
        if kinds.get(head) == "classification":
            if got < target - 1e-12:
                return False
        elif got > target + 1e-12:
            return False
    return True


def _head_values(m: dict[str, Any]) -> tuple[dict[str, float | None], dict[str, str]]:
    values: dict[str, float | None] = {}
    kinds: dict[str, str] = {}
    for name, h in (m.get("heads") or {}).items():
        kind = "regression" if h.get("kind") == "regression" else "classification"
        value = h.get("mae") if kind == "regression" else h.get("accuracy")
        kinds[name] = kind
        values[name] = float(value) if isinstance(value, int | float) else None
    return values, kinds


def read_point(run_dir: Path, data_name: str, metric: str, label: str = "") -> RunPoint:
    """The :class:`RunPoint` of ``RUN/eval/<data_name>/metrics.json``."""
    path = run_dir / runs.EVAL_DIR / data_name / runs.METRICS_JSON
    if not path.exists() and not path.is_symlink():
        raise InputError(f"no evaluation named {data_name!r}; run `tactile evaluate`",
                         path=run_dir)
    m = runs.read_metrics(path)
    score = _score(m, metric, path)
    head = m["heads"][m["primary_head"]]
    lat = m.get("latency") or {}
    model = m.get("model") or {}
    values, kinds = _head_values(m)
    exported = m.get("exported") if isinstance(m.get("exported"), dict) else {}
    exported_lat = exported.get("latency") if isinstance(exported.get("latency"), dict) else {}
    exported_ms = exported_lat.get("batch1_ms_median")
    return RunPoint(
        run=str(run_dir), label=label or f"{m.get('family', '?')}/{run_dir.name}",
        family=str(m.get("family", "?")), eval_name=data_name, metrics_path=str(path),
        score=score, accuracy=head.get("accuracy"), macro_f1=head.get("macro_f1"),
        latency_ms=lat.get("batch1_ms_median"), latency_p95_ms=lat.get("batch1_ms_p95"),
        windows_per_s=lat.get("windows_per_s"), n_params=int(model.get("n_params", 0)),
        size_mb=float(model.get("size_mb", math.nan)), n_windows=int(m.get("n_windows", 0)),
        split=str(m.get("split", "")), primary_head=str(m["primary_head"]),
        data=[{k: d.get(k) for k in ("path", "sha256", "recordings_sha256", "n_trials")}
              for d in m.get("data", [])],
        latency_threads=lat.get("threads"), cpu=str(lat.get("cpu", "")),
        input=m.get("input"), score_ci95=_score_ci(m, metric),
        head_values=values, head_kinds=kinds,
        exported_latency_ms=float(exported_ms) if isinstance(exported_ms, int | float)
        and not isinstance(exported_ms, bool) else None,
        exported_runtime=str(exported.get("runtime", "")),
    )


SPREAD_JSON = "seed_spread.json"
#: the evaluation name of every seed's run in a seed-spread folder
SPREAD_EVAL = "seed_spread"


def spread_runs(path: Path) -> list[Path] | None:
    """The seed runs (``seed_S/``) of a ``tactile seed-spread`` folder, in its seed order;
    None when ``path`` is not one (no seed_spread.json)."""
    record = path / SPREAD_JSON
    if not (path.is_dir() and record.is_file()):
        return None
    seeds = read_spread_record(record).get("seeds")
    if not isinstance(seeds, list) or not seeds or not all(
            isinstance(s, int) and not isinstance(s, bool) for s in seeds):
        raise InputError("holds no list of seeds; re-create it with `tactile seed-spread`",
                         path=record)
    return [check_run_folder(path / f"seed_{s}") for s in seeds]


def read_spread_record(record: Path) -> dict[str, Any]:
    """A ``seed_spread.json`` as a dict; one :class:`InputError` when it cannot be read."""
    import json

    try:
        data = json.loads(record.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"not a readable seed-spread record ({exc.__class__.__name__}); "
                         "re-create it with `tactile seed-spread`", path=record) from None
    if not isinstance(data, dict) or data.get("format") != "tactile-seed-spread":
        raise InputError("not a seed-spread record (format tactile-seed-spread); re-create it "
                         "with `tactile seed-spread`", path=record)
    return data


def spread_point(point: RunPoint, members: Sequence[Path], folder: Path, data_name: str,
                 metric: str) -> RunPoint:
    """``point`` (the first seed's) turned into the point of the whole spread: scores and
    head values averaged over the seeds (:attr:`RunPoint.seeds`)."""
    metrics = [runs.read_metrics(m / runs.EVAL_DIR / data_name / runs.METRICS_JSON)
               if (m / runs.EVAL_DIR / data_name / runs.METRICS_JSON).is_file() else None
               for m in members]
    for m, got in zip(members, metrics, strict=True):
        if got is None:
            raise InputError(f"no evaluation named {data_name!r}; re-create the spread with "
                             "`tactile seed-spread`", path=m)
    scores = [_score(m, metric, member) for m, member in zip(metrics, members, strict=True)]

    def mean(values: Sequence[float | None]) -> float | None:
        kept = [v for v in values if v is not None]
        return float(np.mean(kept)) if len(kept) == len(values) else None

    heads = [_head_values(m)[0] for m in metrics]
    primary = [m["heads"][m["primary_head"]] for m in metrics]
    point.run = str(folder)
    point.score = float(np.mean(scores))
    point.accuracy = mean([h.get("accuracy") for h in primary])
    point.macro_f1 = mean([h.get("macro_f1") for h in primary])
    point.head_values = {k: mean([h.get(k) for h in heads]) for k in heads[0]}
    point.score_ci95 = None
    point.seeds = {"n": len(scores), "seeds": [m.name.removeprefix("seed_") for m in members],
                   "scores": scores,
                   "sd": float(np.std(scores, ddof=1)) if len(scores) > 1 else 0.0,
                   "min": min(scores), "max": max(scores)}
    return point


def seed_notes(cmp: Comparison) -> list[str]:
    """Where the seed spread is larger than what the choice rests on: a run within one seed
    SD (the largest of the spreads) of the margin's edge, and a chosen run closer to the
    best than the seed SD."""
    notes = []
    spread = [p for p in cmp.points if p.seeds is not None and p.seeds["n"] > 1]
    if not spread:
        return notes
    worst = max(spread, key=lambda p: p.seeds["sd"])
    sd_pp = 100 * worst.seeds["sd"]
    edge = [p for p in cmp.points if p is not cmp.best
            and abs(100 * (cmp.best.score - p.score) - cmp.margin_pp) < sd_pp]
    if not cmp.targets and edge:
        notes.append(f"{', '.join(p.label for p in edge)}: within one seed SD ({sd_pp:.2f} pp, "
                     f"{worst.label}) of the margin's edge ({cmp.margin_pp:g} pp below the "
                     "best), so whether it is within the margin can change with the seed")
    n = cmp.needed
    if n is not None and n is not cmp.best:
        gap_pp = 100 * (cmp.best.score - n.score)
        sds = [100 * p.seeds["sd"] for p in (n, cmp.best) if p.seeds is not None]
        if sds and gap_pp < max(sds):
            notes.append(f"{n.label} and {cmp.best.label} differ by {gap_pp:.2f} pp, less than "
                         f"their seed SD ({max(sds):.2f} pp): the seed could reorder them")
    return notes


def _recordings(data: Sequence[dict[str, Any]]) -> list[tuple[tuple[str, ...], int]]:
    """Per data file: the recordings it holds (see
    :func:`~tactile_cli.store.reader.recording_hashes`; older metrics files without them:
    the file's own SHA-256) and its number of trials, sorted."""
    return sorted((tuple(d.get("recordings_sha256") or [d["sha256"]]),
                   int(d.get("n_trials") or 0)) for d in data)


def _check_same_data(points: Sequence[RunPoint]) -> None:
    """Refuse runs evaluated on other recordings (or other trials of them, or another
    split). Two files hold the same recordings when they are the same file, or when one
    is derived from the other's source (``tactile centroids`` turns a scene file into ROI
    centroid streams: the spatial and the temporal models then score the same trials)."""
    ref = points[0]
    ref_recordings = _recordings(ref.data)
    for p in points[1:]:
        if _recordings(p.data) != ref_recordings:
            raise InputError(
                f"evaluation {p.eval_name!r} used other recordings than {ref.run} "
                f"({', '.join(str(d['path']) for d in p.data)} vs "
                f"{', '.join(str(d['path']) for d in ref.data)}); evaluate every run on the "
                "same files, or on files derived from them (tactile centroids), with the "
                "same trials", path=p.metrics_path)
        if p.split != ref.split:
            raise InputError(f"evaluation split is {p.split!r} here but {ref.split!r} in "
                             f"{ref.run}; evaluate every run with the same "
                             "`tactile evaluate --split`",
                             path=p.metrics_path)


def _check_inputs(points: Sequence[RunPoint], infos: Sequence[dict[str, Any]]) -> list[str]:
    """Refuse an evaluation of data other than its run's input (sample period more than
    0.1 % off, other channels or units); return a note for each pair that could not be
    checked because run.json or metrics.json predates the record."""
    notes = []
    for p, info in zip(points, infos, strict=True):
        run_json = Path(p.run) / runs.RUN_JSON
        trained = None if "input" not in info else InputSpec.from_dict(info["input"],
                                                                       path=run_json)
        data = None if p.input is None else InputSpec.from_dict(p.input, path=p.metrics_path)
        if trained is None or data is None:
            older, redo = ("run.json", "train") if trained is None \
                else ("metrics.json", "evaluate")
            notes.append(f"{p.label}: {older} records no input sample period or channels, so "
                         f"evaluation {p.eval_name!r} was not checked to be of data like the "
                         f"training data; re-run `tactile {redo}` to have it checked")
            continue
        found = mismatch(data, trained)
        if found is not None:
            raise InputError(f"the evaluation data's {found[0]}; re-run `tactile evaluate "
                             f"{p.run} --data FILE` on data of the run's input, or retrain",
                             path=p.metrics_path)
    return notes


def check_targets(targets: dict[str, float], points: Sequence[RunPoint]) -> None:
    """Refuse a target for a head some run lacks, and an accuracy target outside 0..1."""
    for head, value in targets.items():
        if not math.isfinite(value) or value < 0:
            raise InputError(f"target {head}={value}: give a number >= 0")
        for p in points:
            if head not in p.head_kinds:
                raise InputError(f"target {head!r}: run {p.label} has no head {head!r} (its "
                                 f"heads: {', '.join(p.head_kinds) or 'none'})")
            if p.head_kinds[head] == "classification" and value > 1:
                raise InputError(f"target {head}={value:g}: an accuracy target is a "
                                 f"fraction (0.948 for 94.8 %)")


def compare_points(points: Sequence[RunPoint], *, margin_pp: float = 0.5,
                   metric: str = "accuracy", data_name: str = "",
                   targets: dict[str, float] | None = None) -> Comparison:
    """Mark the Pareto front and the margin on ``points`` (in place) and choose: the
    fewest parameters within the margin, or, with ``targets``, meeting every target."""
    if not points:
        raise InputError("no runs to compare; give RUN folders")
    if not (math.isfinite(margin_pp) and margin_pp >= 0):
        raise InputError(f"`margin_pp` must be a number >= 0 (percentage points), got {margin_pp}")
    score = np.array([p.score for p in points], dtype=np.float64)
    lat = np.array([math.nan if p.latency_ms is None else p.latency_ms for p in points])
    n_params = np.array([p.n_params for p in points], dtype=np.int64)
    labels = [p.label for p in points]
    front = pareto_front(score, lat)
    near = within_margin(score, margin_pp)
    for p, f, w in zip(points, front, near, strict=True):
        p.pareto, p.within_margin = bool(f), bool(w)
    best = int(max(range(len(points)), key=lambda i: (score[i], -n_params[i])))
    targets = dict(targets or {})
    eligible = near
    if targets:
        check_targets(targets, points)
        for p in points:
            p.meets_targets = meets_targets(p.head_values, p.head_kinds, targets)
        eligible = np.array([bool(p.meets_targets) for p in points])
    needed = pick_needed(n_params, lat, eligible, labels) if eligible.any() else None
    fastest = pick_fastest(n_params, lat, eligible, labels) if eligible.any() else None
    on_front = sorted((p for p in points if p.pareto), key=lambda p: (p.latency_ms, -p.score))
    return Comparison(list(points), metric, data_name, float(margin_pp), points[best],
                      None if needed is None else points[needed],
                      None if fastest is None else points[fastest], on_front,
                      targets=targets)


def compare(run_dirs: Sequence[str | Path], *, data_name: str | None = None,
            margin_pp: float = 0.5, metric: str = "accuracy",
            targets: dict[str, float] | None = None) -> Comparison:
    """Read every run's evaluation on the same data and compare them.

    ``data_name`` is the folder name under ``RUN/eval/`` (default: the one all runs
    share). Raises :class:`InputError` for a missing run or evaluation, evaluations of
    different data, or a run without a classification head.
    """
    given = [Path(d) for d in run_dirs]
    if not given:
        raise InputError("no runs to compare; give RUN folders")
    members = [spread_runs(d) for d in given]  # a seed-spread folder: its seed runs
    dirs = [check_run_folder(d) if m is None else m[0] for d, m in zip(given, members,
                                                                          strict=True)]
    seen: set[Path] = set()
    for d in given:  # checked above: no longer a broken link or a loop
        if d.resolve() in seen:
            raise InputError("run given twice", path=d)
        seen.add(d.resolve())
    families, infos = [], []
    for d in dirs:
        info = runs.read_run_info(d)
        families.append(info["model"]["family"])
        infos.append(info)
    plain = [d for d, m in zip(dirs, members, strict=True) if m is None]
    spread_first = [d for d, m in zip(dirs, members, strict=True) if m is not None]
    if plain and spread_first:  # spreads are read at their own evaluation, on the same data,
        name = choose_data_name(plain, data_name)  # or at `data_name` when every one has it
        spread_name = choose_data_name(spread_first, data_name if data_name is not None and all(
            data_name in eval_names(d) for d in spread_first) else SPREAD_EVAL)
    else:
        name = spread_name = choose_data_name(dirs, data_name)
    labels = run_labels(given, families)
    points = [read_point(d, name if m is None else spread_name, metric, lab)
              for d, m, lab in zip(dirs, members, labels, strict=True)]
    for i, m in enumerate(members):
        if m is not None:
            points[i] = spread_point(points[i], m, given[i], spread_name, metric)
    _check_same_data(points)
    notes = _check_inputs(points, infos)
    cmp = compare_points(points, margin_pp=margin_pp, metric=metric, data_name=name,
                         targets=targets)
    cmp.notes = notes + seed_notes(cmp)
    cmp.inputs = [{"path": p.metrics_path, "sha256": sha256_of(p.metrics_path)}
                  for p in points]
    return cmp


# -- outputs ---------------------------------------------------------------------------------
TABLE_COLUMNS = ("label", "family", "score_pct", "delta_pp", "accuracy_pct", "macro_f1",
                 "latency_ms_median", "latency_ms_p95", "windows_per_s", "n_params",
                 "size_mb", "pareto", "within_margin", "needed", "fastest", "meets_targets",
                 "run", "exported_latency_ms", "n_seeds", "seed_sd_pp")


def table_rows(cmp: Comparison) -> list[dict[str, Any]]:
    """One dict per run with :data:`TABLE_COLUMNS` (percentages in %, delta to the best in
    percentage points)."""
    rows = []
    for p in cmp.points:
        rows.append({
            "label": p.label, "family": p.family, "score_pct": 100 * p.score,
            "delta_pp": 100 * (p.score - cmp.best.score),
            "accuracy_pct": None if p.accuracy is None else 100 * p.accuracy,
            "macro_f1": p.macro_f1, "latency_ms_median": p.latency_ms,
            "latency_ms_p95": p.latency_p95_ms, "windows_per_s": p.windows_per_s,
            "n_params": p.n_params, "size_mb": p.size_mb, "pareto": p.pareto,
            "within_margin": p.within_margin, "needed": p is cmp.needed,
            "fastest": p is cmp.fastest, "meets_targets": p.meets_targets, "run": p.run,
            "exported_latency_ms": p.exported_latency_ms,
            "n_seeds": None if p.seeds is None else p.seeds["n"],
            "seed_sd_pp": None if p.seeds is None else 100 * p.seeds["sd"],
        })
    return rows


def plot_comparison(cmp: Comparison, *, title: str | None = None) -> bytes:
    """The chart as PNG bytes: score (%) against batch-1 median latency per window (ms, log
    axis), every run labelled ``family/name``, the Pareto front as a dashed staircase with
    ringed points, the margin band under the best score, the needed model starred and
    the fastest within the margin as a diamond; a run whose evaluation has a 95 % interval
    of the score (cross-validated runs) gets it as a vertical error bar; a run evaluated
    with its exported model (``--exported``) gets a hollow square at that model's latency,
    joined to its torch point. Runs without latency are listed below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fams = sorted({p.family for p in cmp.points})
    colour = {f: f"C{i % 10}" for i, f in enumerate(fams)}
    fig, ax = plt.subplots(figsize=(10.5, 5.2))
    timed = [p for p in cmp.points if p.latency_ms is not None and p.latency_ms > 0]
    for fam in fams:
        pts = [p for p in timed if p.family == fam]
        if pts:
            ax.scatter([p.latency_ms for p in pts], [100 * p.score for p in pts], s=46,
                       color=colour[fam], label=fam, zorder=3)
            for p in pts:
                if p.score_ci95 is not None:
                    lo, hi = (100 * v for v in p.score_ci95)
                    ax.errorbar([p.latency_ms], [100 * p.score], capsize=3, lw=1,
                                yerr=[[max(0.0, 100 * p.score - lo)],
                                      [max(0.0, hi - 100 * p.score)]],
                                color=colour[fam], alpha=0.6, zorder=2.5)
    deployed = [p for p in timed if p.exported_latency_ms and p.exported_latency_ms > 0]
    for i, p in enumerate(deployed):
        ax.plot([p.latency_ms, p.exported_latency_ms], [100 * p.score] * 2, color="0.5",
                lw=0.8, ls=":", zorder=2)
        ax.scatter([p.exported_latency_ms], [100 * p.score], marker="s", s=46,
                   facecolors="none", edgecolors=colour[p.family], lw=1.4, zorder=3,
                   label="exported model (onnxruntime / TorchScript)" if i == 0 else None)
        ax.annotate(f"{p.label} (exported)", (p.exported_latency_ms, 100 * p.score),
                    xytext=(6, -11), textcoords="offset points", fontsize=7, color="0.3",
                    zorder=6)
    if cmp.pareto:
        xs = [p.latency_ms for p in cmp.pareto]
        ys = [100 * p.score for p in cmp.pareto]
        ax.step(xs, ys, where="post", ls="--", color="0.35", lw=1.2, zorder=2,
                label="Pareto front")
        ax.scatter(xs, ys, s=150, facecolors="none", edgecolors="0.2", lw=1.2, zorder=4)
    best = 100 * cmp.best.score
    ax.axhspan(best - cmp.margin_pp, best, color="C2", alpha=0.12, zorder=1,
               label=f"within {cmp.margin_pp:g} pp of the best")
    if cmp.needed is not None and cmp.needed.latency_ms:
        ax.scatter([cmp.needed.latency_ms], [100 * cmp.needed.score], marker="*", s=320,
                   color="gold", edgecolors="black", zorder=5,
                   label=f"needed: {cmp.needed.label}")
    if cmp.fastest is not None and cmp.fastest.latency_ms:
        ax.scatter([cmp.fastest.latency_ms], [100 * cmp.fastest.score], marker="D", s=80,
                   facecolors="none", edgecolors="C3", lw=1.6, zorder=5,
                   label=f"fastest within margin: {cmp.fastest.label}")
    for p in timed:
        ax.annotate(p.label, (p.latency_ms, 100 * p.score), xytext=(6, 5),
                    textcoords="offset points", fontsize=8, zorder=6)
    if timed:
        from matplotlib.ticker import FuncFormatter

        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if
                                                   f"{v:.1e}"[0] in "25" else ""))
        xs_all = [p.latency_ms for p in timed] + [p.exported_latency_ms for p in deployed]
        lo, hi = min(xs_all), max(xs_all)
        ax.set_xlim(lo / 1.6, hi * 2.2)  # room for the labels on the right
    ys_all = [100 * p.score for p in cmp.points] + [
        100 * v for p in timed if p.score_ci95 is not None for v in p.score_ci95]
    span = max(max(ys_all) - min(ys_all), cmp.margin_pp, 0.5)
    ax.set_ylim(min(ys_all) - 0.15 * span, max(ys_all) + 0.15 * span)
    ax.set_xlabel("latency per window, batch 1, median (ms)")
    ax.set_ylabel(f"{cmp.metric_label} (%)")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(title or f"{cmp.metric_label} against latency on {cmp.data_name} "
                          f"({len(cmp.points)} runs)", fontsize=10)
    missing = [p.label for p in cmp.points if p not in timed]
    if missing:
        fig.text(0.01, 0.01, "no latency measured (not drawn): " + ", ".join(missing),
                 fontsize=7)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": f"tactile {__version__}"})
    plt.close(fig)
    return buf.getvalue()


@dataclass(frozen=True)
class ComparisonFiles:
    png: Path
    csv: Path
    json: Path


def comparison_record(cmp: Comparison, *, command: str | None = None) -> dict[str, Any]:
    """compare.json: the comparison with its provenance."""
    return {
        "format": COMPARE_FORMAT, "format_version": COMPARE_FORMAT_VERSION,
        "tool_version": __version__, "created_utc": utc_now(),
        "command": command if command is not None else current_command(),
        "inputs": cmp.inputs, **cmp.as_dict(), "summary": cmp.summary(),
        "table": table_rows(cmp),
    }


def write_comparison(cmp: Comparison, out_dir: str | Path, *, command: str | None = None
                     ) -> ComparisonFiles:
    """Write compare.png, compare.csv and compare.json into ``out_dir`` (created; other
    files there are kept): all three are written into a hidden folder beside it and moved
    in together, so an error or interrupt leaves ``out_dir`` as it was."""
    out = check_output_folder(out_dir, merge=True)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(TABLE_COLUMNS), lineterminator="\n")
    w.writeheader()
    for row in table_rows(cmp):
        w.writerow({k: "" if v is None else v for k, v in row.items()})
    # built beside ``out_dir`` and moved in only when all three are written
    with output_folder(out, merge=True) as tmp:
        write_bytes(tmp / COMPARE_PNG, plot_comparison(cmp))
        write_text(tmp / COMPARE_CSV, buf.getvalue())
        write_text(tmp / COMPARE_JSON, runs.dumps(comparison_record(cmp, command=command))
                   + "\n")
    return ComparisonFiles(out / COMPARE_PNG, out / COMPARE_CSV, out / COMPARE_JSON)


def parse_targets(items: Sequence[str]) -> dict[str, float]:
    """``["motion=0.948", "speed_cm_s=3.4"]`` -> ``{"motion": 0.948, "speed_cm_s": 3.4}``."""
    out: dict[str, float] = {}
    for item in items:
        head, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not sep or not head.strip() or not math.isfinite(number):
            raise InputError(f"`targets` {item!r}: give HEAD=VALUE, e.g. motion=0.948")
        if head.strip() in out:
            raise InputError(f"`targets` {head.strip()!r} given twice")
        out[head.strip()] = number
    return out


def compare_runs(run_dirs: Sequence[str | Path], *, data_name: str | None = None,
                 margin_pp: float = 0.5, metric: str = "accuracy",
                 targets: Mapping[str, float] | Sequence[str] | None = None,
                 out_dir: str | Path | None = None, command: str | None = None
                 ) -> Comparison:
    """What ``tactile compare`` does: :func:`compare` the runs (``targets`` as a mapping
    or as ``HEAD=VALUE`` strings) and, with ``out_dir``, write compare.png, .csv and .json
    there (:func:`write_comparison`; the comparison's ``files``). The output folder is
    checked before the runs are read."""
    from ..input_guard import check_outputs

    wanted = dict(targets) if isinstance(targets, Mapping) else parse_targets(targets or [])
    if out_dir is not None:
        check_outputs({"out_dir": out_dir}, [Path(d) / runs.RUN_JSON for d in run_dirs])
        check_output_folder(out_dir, merge=True)
    cmp = compare(run_dirs, data_name=data_name, margin_pp=margin_pp, metric=metric,
                  targets=wanted)
    if out_dir is not None:
        cmp.files = write_comparison(cmp, out_dir, command=command)
    return cmp


__all__ = ["COMPARE_CSV", "COMPARE_JSON", "COMPARE_PNG", "Comparison", "ComparisonFiles",
           "RunPoint", "check_run_folder", "choose_data_name", "compare", "compare_points",
           "compare_runs", "comparison_record", "distinct_run_paths", "eval_names",
           "parse_targets", "pareto_front", "pick_fastest", "pick_needed", "plot_comparison",
           "read_point", "run_labels", "table_rows", "within_margin", "write_comparison"]
