"""How much of a figure is the seed: one config trained and evaluated at several seeds.

On a small real set a figure can move more with the seed (initial weights, batch order, a
forest's bootstraps) than between the models it is meant to rank: on the 20 GelSight lifts
the CNN-LSTM decided 85 % of an unseen object's lifts at seed 0 and 65-70 % at seeds 1-4
(benchmarks/RESULTS.md, "Seeds"). :func:`seed_spread` trains ``config`` once per seed, as
``tactile train CONFIG --data FILE... --cv K --seed S`` does, into ``OUT/seed_S/``, and
evaluates each run as ``tactile evaluate`` does: a cross-validated run on its held-out
folds, a single run on ``eval_data`` (trials it never saw). It then reports every seed's
figures beside their mean, sample SD, min, max and spread.

Outputs in ``OUT/``:

- ``seed_S/``: a run folder per seed (``tactile evaluate``, ``compare``, ``report`` read it),
  its evaluation in ``seed_S/eval/seed_spread/``;
- ``seed_spread.json``: the plan and its provenance (command, tool version, config and data
  with SHA-256), one row per seed, the summary (:data:`METRICS` -> mean, sd, min, max,
  spread, n_seeds);
- ``seed_spread.md``: the same as a table; ``seed_spread.png``: each seed's figure as a dot,
  the mean and +- 1 SD as a bar.

The spread is built beside ``OUT`` in ``.OUT.seed-spread-partial/`` (:func:`partial_dir`)
and renamed to ``OUT`` when every seed is done, so an earlier ``OUT`` (replaced only with
``overwrite``) stays as it was until then. A stopped spread resumes there: a seed whose
evaluation exists is read back, a cross-validation under way resumes its finished folds.
The partial folder's ``.seed_spread_plan.json`` holds the config, data and settings it was
started with; another plan there is refused unless ``overwrite`` (which discards it).

With a split that does not depend on the seed (``data.split`` grouped or blocked, or
``--split-from``) every seed is scored on the same trials, so the spread is the training's
alone; a random or stratified split is drawn from the seed too, and the record says so
(``split_depends_on_seed``). The seeds are independent tasks of :func:`..batch.map_tasks`
(local worker processes, an existing Dask cluster, or this process one after another); a
seed's folds train one after another in its task (``jobs=1``) on the config's
``optim.threads``, so its figures do not depend on where or beside what it ran.
"""

from __future__ import annotations

import json
import shutil
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._version import __version__
from ..errors import InputError
from ..input_guard import check_outputs
from ..store.atomic import save_figure, swap_into_place, write_json, write_text
from ..store.outdir import check_output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .compare import SPREAD_EVAL, SPREAD_JSON

if TYPE_CHECKING:
    from ..batch import BatchCounts
    from .metrics import EvalResult

#: metric name -> where it is in the primary head of metrics.json
METRICS: dict[str, tuple[str, ...]] = {
    "window_accuracy": ("accuracy",),
    "window_macro_f1": ("macro_f1",),
    "trial_majority_accuracy": ("per_trial", "majority_accuracy"),
    "trial_mean_probability_accuracy": ("per_trial", "mean_probability_accuracy"),
    "group_mean_probability_accuracy": ("per_group", "mean_probability_accuracy"),
}
#: how the table and the figure name each metric
LABELS = {
    "window_accuracy": "window accuracy", "window_macro_f1": "window macro F1",
    "trial_majority_accuracy": "per trial, majority",
    "trial_mean_probability_accuracy": "per trial, mean prob.",
    "group_mean_probability_accuracy": "per group, mean prob.",
}
EVAL_NAME = SPREAD_EVAL  # each seed's evaluation: seed_S/eval/seed_spread/
PLAN_JSON = ".seed_spread_plan.json"
RECORD_JSON = SPREAD_JSON
TABLE_MD = "seed_spread.md"
FIGURE_PNG = "seed_spread.png"
MAX_SEEDS = 100


def parse_seeds(text: str | Sequence[int]) -> list[int]:
    """Seeds from ``"0,1,2"``, ``"0-4"`` or a mix (``"0-2,7"``), or a list of ints; each
    seed >= 0, none twice, at most :data:`MAX_SEEDS`."""
    if not isinstance(text, str):
        seeds = [int(s) for s in text]
    else:
        seeds = []
        for part in text.split(","):
            part = part.strip()
            lo, dash, hi = part.partition("-")
            try:
                if dash:
                    a, b = int(lo), int(hi)
                    if b < a:
                        raise ValueError
                    seeds.extend(range(a, b + 1))
                else:
                    seeds.append(int(part))
            except ValueError:
                raise InputError(f"`seeds` must be integers >= 0 such as 0,1,2 or 0-4, got "
                                 f"{text!r}") from None
    if not seeds:
        raise InputError("`seeds` names no seed; give e.g. 0-4")
    if min(seeds) < 0:
        raise InputError(f"`seeds` must be >= 0, got {min(seeds)}")
    twice = sorted({s for s in seeds if seeds.count(s) > 1})
    if twice:
        raise InputError(f"`seeds` gives seed {twice[0]} twice")
    if len(seeds) > MAX_SEEDS:
        raise InputError(f"`seeds` names {len(seeds)} seeds; at most {MAX_SEEDS}")
    return seeds


def _get(head: dict[str, Any], path: tuple[str, ...]) -> float | None:
    value: Any = head
    for key in path:
        if not isinstance(value, dict) or value.get(key) is None:
            return None
        value = value[key]
    return float(value)


@dataclass
class SeedRow:
    """One seed's figures (fractions; None where the evaluation has no such figure), its
    support (windows and trials scored) and its folds."""

    seed: int
    run: str
    metrics: dict[str, float | None]
    n_windows: int
    n_trials: int
    folds: list[dict[str, Any]] = field(default_factory=list)
    wall_time_s: float = 0.0
    resumed: bool = False
    warnings: list[str] = field(default_factory=list)
    """The evaluation's notes and warnings (support, fold plan, interleaving, shift)."""

    def as_dict(self) -> dict[str, Any]:
        return {"seed": self.seed, "run": self.run, **self.metrics,
                "n_windows": self.n_windows, "n_trials": self.n_trials, "folds": self.folds,
                "wall_time_s": self.wall_time_s, "resumed": self.resumed,
                "warnings": self.warnings}


def summarise(rows: Sequence[SeedRow]) -> dict[str, dict[str, float]]:
    """metric -> mean, sample SD (ddof 1; 0 with one seed), min, max, spread (max - min)
    and n_seeds, over the seeds that have the metric."""
    out: dict[str, dict[str, float]] = {}
    for name in METRICS:
        values = [v for r in rows if (v := r.metrics.get(name)) is not None]
        if not values:
            continue
        out[name] = {"mean": statistics.fmean(values),
                     "sd": statistics.stdev(values) if len(values) > 1 else 0.0,
                     "min": min(values), "max": max(values),
                     "spread": max(values) - min(values), "n_seeds": len(values)}
    return out


@dataclass
class SeedSpread:
    """Everything ``tactile seed-spread`` reports (``as_dict`` is seed_spread.json)."""

    out_dir: Path
    plan: dict[str, Any]
    rows: list[SeedRow]
    summary: dict[str, dict[str, float]]
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {**self.plan, "out_dir": str(self.out_dir),
                "by_seed": [r.as_dict() for r in self.rows], "summary": self.summary,
                "notes": self.notes}

    def table(self) -> str:
        """Markdown: one row per seed, then mean, sd, min, max, spread (percent)."""
        names = [n for n in METRICS if n in self.summary]
        lines = ["| seed | " + " | ".join(LABELS[n] for n in names) + " | windows | trials |",
                 "|---:|" + "---:|" * (len(names) + 2)]
        for r in self.rows:
            cells = ["-" if r.metrics.get(n) is None else f"{100 * r.metrics[n]:.1f} %"
                     for n in names]
            lines.append(f"| {r.seed} | " + " | ".join(cells)
                         + f" | {r.n_windows} | {r.n_trials} |")
        for stat in ("mean", "sd", "min", "max", "spread"):
            digits = 2 if stat in ("sd", "spread") else 1
            lines.append(f"| {stat} | " + " | ".join(
                f"{100 * self.summary[n][stat]:.{digits}f} %" for n in names) + " | | |")
        return "\n".join(lines)


def _plan(config: Path, data: list[Path], eval_data: list[Path], cv: int | str | None,
          epochs: int | None, split_from: Path | None, seeds: list[int], command: str
          ) -> dict[str, Any]:
    from .config import load_config

    cfg = load_config(config)
    mode = "split_from" if split_from is not None else cfg.data.split.mode
    return {
        "format": "tactile-seed-spread", "format_version": 1, "tool_version": __version__,
        "created_utc": utc_now(), "command": command,
        "config": str(config), "config_sha256": sha256_of(config),
        "data": [{"path": str(p), "sha256": sha256_of(p)} for p in data],
        "eval_data": [{"path": str(p), "sha256": sha256_of(p)} for p in eval_data],
        "split_from": None if split_from is None else
        {"path": str(split_from), "sha256": sha256_of(split_from)},
        "cv": cv, "epochs": epochs if epochs is not None else cfg.optim.epochs,
        "split": cfg.data.split.model_dump(mode="json"),
        # which trials are scored: fixed without cv (the eval data) and with leave-one-
        # trial-out folds; drawn from the seed with k random or stratified folds
        "split_depends_on_seed": cv is not None and cv != "loto"
        and mode in ("auto", "random", "stratified"),
        "seeds": seeds,
    }


_PLAN_KEYS = ("config_sha256", "data", "eval_data", "split_from", "cv", "epochs")


def _same_plan(a: dict[str, Any], b: dict[str, Any]) -> bool:
    def key(p: dict[str, Any]) -> list[Any]:
        return [[d["sha256"] for d in p[k]] if k in ("data", "eval_data")
                else (p[k] or {}).get("sha256") if k == "split_from" else p[k]
                for k in _PLAN_KEYS]
    return key(a) == key(b)


def partial_dir(out: Path) -> Path:
    """Where a spread under way keeps its seeds' runs until every seed is done."""
    return out.with_name(f".{out.name}.seed-spread-partial")


def _start(out: Path, plan: dict[str, Any], overwrite: bool) -> tuple[Path, bool]:
    """The folder to build the spread in (:func:`partial_dir`), made or resumed, and
    whether this call made it. ``out`` itself is only written when the spread is done."""
    check_output_folder(out, overwrite=overwrite)
    work = partial_dir(out)
    check_output_folder(work, merge=True)
    plan_path = work / PLAN_JSON
    if work.is_dir() and any(work.iterdir()):
        try:
            earlier = json.loads(plan_path.read_text(encoding="utf-8"))
            same = _same_plan(earlier, plan)
        except (OSError, ValueError, KeyError, TypeError):
            same = False
        if not same:
            if not overwrite:
                raise InputError("holds a stopped seed spread of another config, data or "
                                 "settings; pass `overwrite=True` to discard it", path=work)
            shutil.rmtree(work)
    made = not work.exists()
    work.mkdir(parents=True, exist_ok=True)
    write_json(plan_path, plan, overwrite=True)
    return work, made


def seed_row(seed: int, run: Path, metrics: dict[str, Any], wall: float,
             resumed: bool) -> SeedRow:
    """A seed's row from its evaluation's metrics.json record."""
    from .tables import drift_messages

    primary = metrics.get("primary_head")
    if primary is None:
        raise InputError("the config has no classification head; a seed spread reports "
                         "accuracy", path=run)
    head = metrics["heads"][primary]
    folds = [{k: f.get(k) for k in ("fold", "accuracy", "per_trial_accuracy")}
             for f in (metrics.get("cv") or {}).get("folds", [])]
    warnings = [str(w) for w in (*(metrics.get("notes") or []), *(metrics.get("warnings") or []))]
    return SeedRow(seed=seed, run=str(run),
                   metrics={n: _get(head, p) for n, p in METRICS.items()},
                   n_windows=int(metrics.get("n_windows") or 0),
                   n_trials=int(metrics.get("n_trials") or 0), folds=folds,
                   wall_time_s=round(wall, 3), resumed=resumed,
                   warnings=list(dict.fromkeys([*warnings, *drift_messages(metrics)])))


def _metrics_path(run: Path) -> Path:
    return run / runs.EVAL_DIR / EVAL_NAME / runs.METRICS_JSON


def _read_own_metrics(run: Path) -> dict[str, Any]:
    """A seed's evaluation record, which this spread wrote and may write again (its latency
    is added at the end): checked like ``tactile evaluate``'s, but not read as an input
    (:func:`.runs.read_metrics` would protect it from that rewrite)."""
    path = _metrics_path(run)
    redo = "delete the seed's folder and run the spread again"
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        raise InputError(f"not a readable evaluation record; {redo}", path=path) from None
    return runs.checked_record(record, path, fmt=runs.EVAL_FORMAT,
                               version=runs.EVAL_FORMAT_VERSION, redo=redo)


def _evaluate(run: Path, eval_data: list[Path], cv: int | str | None, *, latency: bool,
              device: str, command: str) -> EvalResult:
    """``run``'s evaluation ``seed_spread``: its held-out folds, or ``eval_data``."""
    from .cv import evaluate_cv
    from .evaluate import evaluate

    if cv is not None:
        return evaluate_cv(run, None, name=EVAL_NAME, latency=latency, command=command,
                           overwrite=True, device=device)
    return evaluate(run, eval_data, name=EVAL_NAME, latency=latency, command=command,
                    overwrite=True, device=device)


def run_seed(spec: dict[str, Any]) -> SeedRow:
    """One seed, where the batch runs it (a module-level task of :func:`.batch.map_tasks`):
    train ``spec["config"]`` at ``spec["seed"]`` into ``OUT/seed_S`` (a stopped
    cross-validation resumes its folds) and evaluate it, or read back an evaluation that
    exists (a stopped spread of the same plan). ``spec`` holds paths as text and plain
    values."""
    from .pipeline import train_run

    seed, cv, device, command = spec["seed"], spec["cv"], spec["device"], spec["command"]
    eval_data = [Path(p) for p in spec["eval_data"]]
    run = Path(spec["out"]) / f"seed_{seed}"
    if _metrics_path(run).is_file():
        return seed_row(seed, run, _read_own_metrics(run), 0.0, resumed=True)
    started = time.perf_counter()
    trained = (run / runs.RUN_JSON).is_file()
    if not trained:  # a single run left half-written is replaced; a cv run resumes its folds
        train_run(Path(spec["config"]), [Path(p) for p in spec["data"]], out=run, seed=seed,
                  epochs=spec["epochs"], cv=cv, jobs=1,
                  split_from=None if spec["split_from"] is None else Path(spec["split_from"]),
                  overwrite=cv is None, command=command, device=device)
    result = _evaluate(run, eval_data, cv, latency=False, device=device, command=command)
    return seed_row(seed, run, result.as_dict(), time.perf_counter() - started, resumed=trained)


def shared_warnings(rows: Sequence[SeedRow]) -> dict[str, list[int]]:
    """Each distinct evaluation warning -> the seeds whose evaluation gave it (in order)."""
    out: dict[str, list[int]] = {}
    for r in rows:
        for w in r.warnings:
            out.setdefault(w, []).append(r.seed)
    return out


def _time_first_seed(run: Path, eval_data: list[Path], cv: int | str | None, device: str,
                     command: str) -> None:
    """Evaluate ``run`` again with its latency measured, unless its evaluation has one (the
    figures are the same: the same model on the same trials)."""
    if not _read_own_metrics(run).get("latency"):
        _evaluate(run, eval_data, cv, latency=True, device=device, command=command)


def seed_spread(
    config: str | Path,
    data_paths: Sequence[str | Path],
    *,
    out: str | Path,
    seeds: str | Sequence[int] = "0-4",
    cv: int | str | None = 5,
    eval_data: Sequence[str | Path] | None = None,
    epochs: int | None = None,
    split_from: str | Path | None = None,
    overwrite: bool = False,
    device: str = "auto",
    command: str | None = None,
    plot: bool = True,
    latency: bool = True,
    scheduler: str | None = None,
    workers: int | None = None,
    on_seed: Callable[[SeedRow], None] | None = None,
    on_progress: Callable[[BatchCounts], None] | None = None,
) -> SeedSpread:
    """Train and evaluate ``config`` on ``data_paths`` once per seed into ``out`` (module
    docstring). ``cv``: folds per seed (an integer >= 2 or ``"loto"``); None trains one model
    per seed and scores it on ``eval_data`` (required then, refused with ``cv``).
    ``latency``: time the first seed's model at batch 1 once every seed is done (alone in
    this process, so that no seed's training slows it; ``tactile compare`` reads it).
    ``overwrite``: replace an earlier ``out`` (when the spread is done) and discard a stopped
    spread of another plan beside it.
    Seeds run as tasks of :func:`..batch.map_tasks` (``workers`` local processes, default
    the cores, 0: here one after another; or an existing Dask ``scheduler``); each seed
    gives the same figures wherever it runs. ``on_seed`` gets each seed's row as it
    finishes, ``on_progress`` the batch counts. A seed that fails stops the spread with one
    :class:`InputError` naming it once the others are done (their runs stay, to resume)."""
    from ..batch import map_tasks
    from .cv import parse_cv
    from .data import data_files
    from .device import resolve_device

    resolve_device(device)
    seed_list = parse_seeds(seeds)
    config = Path(config)
    if not config.is_file():
        raise InputError("file not found", path=config)
    data = data_files(data_paths)
    evals = data_files(eval_data) if eval_data else []
    if cv is not None:
        cv = parse_cv(cv)
        if evals:
            raise InputError("`eval_data` is for a spread without `cv`: a cross-validated "
                             "seed is scored on its own held-out folds")
    elif not evals:
        raise InputError("`eval_data` is required without `cv`: give the trials to score "
                         "each seed's model on, or cross-validate")
    split = Path(split_from) if split_from is not None else None
    command = command if command is not None else current_command()
    out = Path(out)
    check_outputs({"out": out}, [config, *data, *evals, split])
    plan = _plan(config, data, evals, cv, epochs, split, seed_list, command)
    work, made = _start(out, plan, overwrite)
    specs = [{"seed": seed, "config": str(config), "data": [str(p) for p in data],
              "eval_data": [str(p) for p in evals], "cv": cv, "epochs": epochs,
              "split_from": None if split is None else str(split), "out": str(work),
              "device": device, "command": command}
             for seed in seed_list]
    rows: list[SeedRow] = []
    failed: list[tuple[int, str]] = []
    for task in map_tasks(run_seed, specs, keys=[f"seed_{s}" for s in seed_list],
                          scheduler=scheduler, workers=workers, on_progress=on_progress):
        if task.ok:
            rows.append(task.value)
            if on_seed is not None:
                on_seed(task.value)
        else:
            failed.append((seed_list[task.index], str(task.error)))
    if failed:
        if made and not rows:  # bad data or config: nothing here worth keeping
            shutil.rmtree(work, ignore_errors=True)
        seed, error = min(failed)
        more = f" ({len(failed) - 1} more seed(s) failed)" if len(failed) > 1 else ""
        raise InputError(f"seed {seed}: {error}{more}")
    rows.sort(key=lambda r: seed_list.index(r.seed))
    if latency:
        _time_first_seed(work / f"seed_{seed_list[0]}", evals, cv, device, command)
    result = SeedSpread(out_dir=out, plan=plan, rows=rows, summary=summarise(rows))
    if plan["split_depends_on_seed"] and cv is not None:
        result.notes.append(f"data.split is {plan['split']['mode']}: the folds are drawn from "
                            "the seed too, so the spread mixes the training's seed with "
                            "which trials are held out")
    for text, seeds in shared_warnings(rows).items():
        who = "every seed" if len(seeds) == len(rows) else "seed(s) " + ", ".join(map(str, seeds))
        result.notes.append(f"{who}: {text}")
    if len(rows) < 3:
        result.notes.append(f"{len(rows)} seed(s): too few for an SD to mean much; give 5 or "
                            "more")
    for row in rows:  # where each run will be once the spread is in place
        name = Path(row.run).name
        row.run = runs.name_final_run(work / name, EVAL_NAME, out / name)
    write_text(work / TABLE_MD, result.table() + "\n", overwrite=True)
    if plot:
        plot_spread(result, work / FIGURE_PNG)
    write_json(work / RECORD_JSON, result.as_dict(), overwrite=True)
    (work / PLAN_JSON).unlink()
    swap_into_place(work, out)
    return result


def plot_spread(result: SeedSpread, path: Path) -> Path:
    """Each seed's figure as a dot per metric (percent), the mean with +- 1 SD as a bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in METRICS if n in result.summary]
    fig, ax = plt.subplots(figsize=(1.8 + 1.6 * max(len(names), 1), 3.8))
    for i, name in enumerate(names):
        values = [100 * v for r in result.rows if (v := r.metrics.get(name)) is not None]
        offsets = [(j - (len(values) - 1) / 2) * 0.06 for j in range(len(values))]
        ax.plot([i + o for o in offsets], values, "o", color="C0", alpha=0.7, ms=5)
        s = result.summary[name]
        ax.errorbar(i + 0.3, 100 * s["mean"], yerr=100 * s["sd"], fmt="s", color="C3",
                    capsize=4)
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels([LABELS[n] for n in names], rotation=15, ha="right")
    ax.set_ylabel("held-out figure (%)")
    seeds = ", ".join(str(r.seed) for r in result.rows)
    ax.set_title(f"{Path(result.plan['config']).name}: seeds {seeds} (dots), mean +- SD",
                 fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    meta = {"Software": f"tactile {__version__}", "Description": result.plan["command"]}
    return save_figure(fig, path, meta=meta, overwrite=True)


def is_spread_folder(path: str | Path) -> bool:
    """Whether ``path`` is a folder ``tactile seed-spread`` wrote (it holds the record)."""
    return Path(path).is_dir() and (Path(path) / RECORD_JSON).is_file()


def spread_lines(path: str | Path) -> tuple[dict[str, Any], list[str]]:
    """The record of a seed-spread folder and its summary for ``tactile info``: config,
    seeds, protocol, data, the table (figures in percent) and the notes."""
    from .compare import read_spread_record

    record = read_spread_record(Path(path) / RECORD_JSON)
    cv = record.get("cv")
    split = record.get("split") if isinstance(record.get("split"), dict) else {}
    how = (f"{cv}-fold cross-validation ({split.get('mode', '?')} split)" if cv not in
           (None, "loto") else "leave one trial out" if cv == "loto" else "scored on " + ", ".join(
               str(d.get("path")) for d in record.get("eval_data") or []))
    lines = [f"{path}: seed spread of {record.get('config')}, seeds "
             f"{', '.join(map(str, record.get('seeds') or []))}, {how}",
             "data: " + ", ".join(str(d.get("path")) for d in record.get("data") or []),
             f"made {record.get('created_utc')} by tactile {record.get('tool_version')}"]
    summary = record.get("summary") if isinstance(record.get("summary"), dict) else {}
    for name in (n for n in METRICS if n in summary):
        st = summary[name]
        lines.append(f"{LABELS[name]}: mean {100 * st['mean']:.1f} %, SD {100 * st['sd']:.2f} "
                     f"pp, {100 * st['min']:.1f}-{100 * st['max']:.1f} %")
    lines += [f"note: {n}" for n in record.get("notes") or []]
    from .spread_eval import spread_evaluations

    for ev in spread_evaluations(Path(path)):  # `tactile evaluate SPREAD --data FILE`
        if "unreadable" in ev:
            lines.append(f"evaluation {ev['name']}: unreadable ({ev['unreadable']})")
            continue
        files = ", ".join(str(d.get("path")) for d in ev.get("data") or [])
        lines.append(f"evaluation {ev.get('name')} on {files}:")
        lines += [f"  {line}" for line in ev.get("against_own") or []]
    return record, lines


def seed_line(row: SeedRow) -> str:
    """One progress line per finished seed: ``seed 3: window accuracy 61.8 % (22 s)``."""
    acc = row.metrics.get("window_accuracy")
    text = "-" if acc is None else f"{100 * acc:.1f} %"
    how = "read back" if row.resumed and row.wall_time_s == 0 else f"{row.wall_time_s:.0f} s"
    return f"seed {row.seed}: window accuracy {text} ({how})"


def spread_summary(result: SeedSpread) -> str:
    """Lines for people: the table and where the outputs are (the notes go to stderr as
    warnings)."""
    lines = [result.table()]
    lines.append(f"wrote {result.out_dir / RECORD_JSON}, {TABLE_MD}, "
                 f"{FIGURE_PNG if (result.out_dir / FIGURE_PNG).exists() else ''}".rstrip(", "))
    return "\n".join(lines)


__all__ = ["METRICS", "SeedRow", "SeedSpread", "is_spread_folder", "parse_seeds",
           "partial_dir", "plot_spread", "spread_lines",
           "run_seed", "seed_line", "seed_row", "seed_spread", "shared_warnings",
           "spread_summary", "summarise"]
