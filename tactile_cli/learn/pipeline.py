"""The file-level verbs of training and evaluation: what ``tactile train`` and ``tactile
evaluate`` do, callable from a notebook.

- :func:`train_run`: a training config (a file or a :class:`~.config.TrainConfig`) and
  data files in, a run folder out: one model (:func:`.train.train`), one per
  cross-validation fold (``cv``: :func:`.cv.train_cv`) or with every trial's split read
  from a CSV (``split_from``).
- :func:`evaluate_run`: a run folder and data files in, ``RUN/eval/<name>/`` out
  (:func:`.evaluate.evaluate`), and with ``perturb`` the breaking points of the run on
  perturbed copies of the data (:func:`.perturb.perturb_runs`).

Both check every option and declare their outputs and inputs before any work (an output
that is an input, contains one or lies inside one is refused, with or without
``overwrite``), and leave the printing to the caller: the results are dataclasses, and the
one-line texts of their progress and summaries are here (:func:`start_line`,
:func:`epoch_line`, :func:`plan_line`, :func:`fold_line`, :func:`train_summary`).

The module and function names differ on purpose: ``tactile_cli.learn.train`` and
``tactile_cli.learn.evaluate`` are the modules, ``train_run`` and ``evaluate_run`` the
verbs (issue 30, item 5).
"""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from ..errors import InputError
from ..input_guard import check_outputs
from ..threads import check_threads

if TYPE_CHECKING:
    from .config import TrainConfig
    from .cv import CvTrainResult
    from .metrics import EvalResult
    from .perturb import PerturbResult
    from .splits import FoldPlan
    from .train import EpochRecord, Prepared, TrainResult


def default_run_dir(config_path: str | Path) -> Path:
    """``runs/<config stem>-<local time>``: where a run goes when no folder is given."""
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{Path(config_path).stem}-{stamp}"


def train_run(
    config: str | Path | TrainConfig,
    data_paths: Sequence[str | Path],
    *,
    out: str | Path | None = None,
    seed: int | None = None,
    epochs: int | None = None,
    cv: int | str | None = None,
    jobs: int | None = None,
    split_from: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    on_start: Callable[[Prepared, TrainConfig], None] | None = None,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    on_plan: Callable[[FoldPlan, list[int]], None] | None = None,
    on_fold: Callable[[int, dict[str, Any]], None] | None = None,
    on_line: Callable[[str], None] | None = None,
    device: str = "auto",
) -> TrainResult | CvTrainResult:
    """Train ``config`` (a YAML file or a validated config; ``seed`` and ``epochs``
    override its own) on ``data_paths`` into run folder ``out`` (default
    :func:`default_run_dir` of the config file).

    ``cv``: cross-validate with ``cv`` folds (an integer >= 2) or ``"loto"``, one model per
    fold, ``jobs`` folds at once (:func:`.cv.train_cv`; a stopped run resumes, and with
    ``overwrite`` an earlier run at ``out`` is replaced only when every fold is done);
    ``split_from``: every trial's split from a CSV (columns trial, split and, where trial
    names repeat across files, file) instead of the config's ``data.split``.
    ``on_start(prepared, config)`` (the data read, the config with the overrides) and
    ``on_epoch`` (one model) or ``on_plan`` and ``on_fold`` (cross-validation) report
    progress; ``on_line`` gets the same as lines for people (:func:`start_line`,
    :func:`plan_line`, :func:`fold_line`; not the epochs). ``device``: ``auto`` (CUDA when
    torch sees it), ``cpu`` or ``cuda`` (:mod:`.device`; recorded in run.json). Returns the
    run's summary (its ``warnings`` include the fold plan's); bad input is one
    :class:`InputError`.
    """
    from .config import TrainConfig, load_config
    from .device import resolve_device

    resolve_device(device)  # a bad value or `cuda` without a GPU: before any work
    config_path = None if isinstance(config, TrainConfig) else Path(config)
    paths = [Path(p) for p in data_paths]
    if not paths:
        raise InputError("no data files; give `data_paths`")
    if cv is not None and split_from is not None:
        raise InputError("`split_from` and `k` exclude each other: cross-validation makes "
                         "its own folds")
    if out is None:
        if config_path is None:
            raise InputError("give the run folder `out` (a config object has no file name "
                             "to name it after)")
        out = default_run_dir(config_path)
    out = Path(out)
    if jobs is not None:
        check_threads(jobs, "jobs")
    inputs = [p for p in (config_path, split_from, *paths) if p is not None]
    check_outputs({"out": out}, inputs)
    if cv is not None:  # and where the finished folds wait for the others
        from .cv import partial_dir

        check_outputs({"out": partial_dir(out)}, inputs)
    cfg = config if isinstance(config, TrainConfig) else load_config(config)
    cfg = _with_overrides(cfg, seed=seed, epochs=epochs)
    family = cfg.model.family

    def started(prep: Prepared) -> None:
        if on_line is not None:
            on_line(start_line(family, prep))
        if on_start is not None:
            on_start(prep, cfg)

    def planned(plan: FoldPlan, finished: list[int]) -> None:
        if on_line is not None:
            on_line(plan_line(family, plan, finished))
        if on_plan is not None:
            on_plan(plan, finished)

    def folded(index: int, summary: dict[str, Any]) -> None:
        if on_line is not None:
            on_line(fold_line(index, summary))
        if on_fold is not None:
            on_fold(index, summary)

    if cv is not None:
        from .cv import parse_cv, train_cv

        return train_cv(cfg, paths, out, k=parse_cv(cv), jobs=jobs, config_path=config_path,
                        overwrite=overwrite, command=command, on_plan=planned,
                        on_fold=folded, device=device)
    from .train import GivenSplits, train

    given = None
    if split_from is not None:
        from .splits import read_split_csv

        given = GivenSplits(read_split_csv(split_from), str(split_from), "csv")
    return train(cfg, paths, out, config_path=config_path, overwrite=overwrite,
                 command=command, on_epoch=on_epoch, on_start=started, given=given,
                 device=device)


def _with_overrides(cfg: TrainConfig, *, seed: int | None, epochs: int | None) -> TrainConfig:
    """The config with ``seed`` and ``epochs`` applied; a value the config refuses is one
    :class:`InputError` naming the argument."""
    from pydantic import ValidationError

    try:
        return cfg.with_overrides(seed=seed, epochs=epochs)
    except ValidationError as exc:
        err = exc.errors()[0]
        name, value = ("seed", seed) if tuple(err["loc"]) == ("seed",) else ("epochs", epochs)
        raise InputError(f"`{name}` (={value}): {str(err['msg']).lower()}") from None


# -- the lines of a training --------------------------------------------------------------------
def start_line(family: str, prep: Prepared) -> str:
    """Trials, split and windows of a training once its data are read."""
    w = prep.windows
    return (f"{family}: {len(prep.trials)} trials ({prep.assignment.mode} split "
            f"{prep.assignment.counts()}), windows train {len(w['train']):,} val "
            f"{len(w['val']):,} test {len(w['test']):,}")


def epoch_line(r: EpochRecord) -> str:
    """One epoch: losses, validation accuracy, ``*`` when it is the best so far."""
    acc = "" if math.isnan(r.val_accuracy) else f" val acc {100 * r.val_accuracy:.2f} %"
    val = "" if math.isnan(r.val_loss) else f" val loss {r.val_loss:.4f}"
    return f"epoch {r.epoch} loss {r.train_loss:.4f}{val}{acc}{' *' if r.best else ''}"


def plan_line(family: str, plan: FoldPlan, finished: Sequence[int]) -> str:
    """The folds of a cross-validation, and how many a stopped run finished."""
    from .splits import fold_text

    again = f", {len(finished)} already finished (resuming)" if finished else ""
    return f"{family}: {fold_text(plan.k, len(plan.folds), plan.mode, plan.by)}{again}"


def fold_line(index: int, summary: dict[str, Any]) -> str:
    """One finished fold: its trials, best epoch, validation accuracy and time."""
    acc = summary.get("best_val_accuracy")
    val = "" if acc is None or math.isnan(acc) else f", val accuracy {100 * acc:.2f} %"
    n = summary["n_trials"]
    return (f"fold {index}: {n['train']} training, {n['val']} validation, {n['test']} "
            f"held-out trials, best epoch {summary['best_epoch']}/{summary['epochs_run']}"
            f"{val}, {summary['train_time_s']:.1f} s")


def train_summary(result: TrainResult | CvTrainResult) -> str:
    """The line ``tactile train`` ends with."""
    from .cv import CvTrainResult
    from .splits import fold_text

    if isinstance(result, CvTrainResult):
        return (f"wrote {result.run_dir}: {result.family}, "
                f"{fold_text(result.k, result.n_folds, result.mode, result.by)}, "
                f"{len(result.trained)} trained in "
                f"{result.wall_time_s:.1f} s with {result.jobs} process(es); evaluate with "
                f"`tactile evaluate {result.run_dir}`")
    acc = result.best_val_accuracy
    return (f"wrote {result.run_dir}: {result.family}, {result.n_params:,} parameters, best "
            f"epoch {result.best_epoch}/{len(result.history)}"
            + ("" if math.isnan(acc) else f", val accuracy {100 * acc:.2f} %")
            + f", trained in {result.train_time_s:.1f} s on {result.threads} thread(s)")


# -- evaluation ---------------------------------------------------------------------------------
@dataclass
class EvaluateRunResult:
    """What ``tactile evaluate`` reports: the evaluation, the perturbation study when asked
    for, and the warnings to show (zero support, notes on the data, evaluation data that
    the run was trained on)."""

    evaluation: EvalResult
    perturbation: PerturbResult | None = None
    warnings: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """metrics.json, or with a perturbation ``{"evaluation", "perturbation"}``."""
        if self.perturbation is None:
            return self.evaluation.as_dict()
        return {"evaluation": self.evaluation.as_dict(),
                "perturbation": self.perturbation.as_dict()}


def evaluate_run(
    run_dir: str | Path,
    data_paths: Sequence[str | Path] | None = None,
    *,
    split: Literal["all", "test"] = "all",
    name: str | None = None,
    latency: bool = True,
    threads: int = 1,
    overwrite: bool = False,
    exported: str | Path | None = None,
    perturb: Sequence[str] | None = None,
    threshold: str = "0.9x",
    shift_threshold_sd: float = 1.0,
    command: str | None = None,
    on_level: Callable[[str, float, float], None] | None = None,
    device: str = "auto",
) -> EvaluateRunResult:
    """Evaluate the run in ``run_dir`` on ``data_paths`` into ``RUN/eval/<name>/`` (see
    :func:`.evaluate.evaluate`; a cross-validated run needs no data: each fold is scored on
    its held-out trials). ``threads``: torch threads of the latency measurement.

    ``perturb``: kinds of perturbation (:data:`.perturb.KINDS`) to re-evaluate the run on
    too, with the breaking point below ``threshold`` (``"0.9x"`` the clean accuracy, or an
    accuracy ``"0.95"``/``"95%"``), into ``RUN/perturb/<name>/``
    (:func:`.perturb.perturb_runs`; ``on_level`` reports each level).
    ``shift_threshold_sd``: a channel whose mean in the evaluated data lies further than
    this many training standard deviations from the training data's is flagged
    (:mod:`.drift`). ``device``: where the model predicts (``auto``, ``cpu``, ``cuda``;
    :mod:`.device`; recorded in metrics.json ``device``).
    """
    from . import runs
    from .device import resolve_device
    from .evaluate import evaluate
    from .perturb import PERTURB_DIR, parse_threshold

    resolve_device(device)  # a bad value or `cuda` without a GPU: before any work
    run_dir = Path(run_dir)
    files = [Path(p) for p in data_paths or []]
    cross_validated = runs.read_run_info(run_dir).get("cv") is not None
    if not files and not cross_validated:
        raise InputError("no data files; give `data_paths`")
    if perturb is not None and cross_validated:
        raise InputError("`perturb` needs one model: give a fold's folder (RUN/folds/fold_00) "
                         "instead of the cross-validated run", path=run_dir)
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    check_threads(threads, "threads")
    runs.check_result_name(name)
    if perturb is not None:
        parse_threshold(threshold)  # a bad value fails before any work
    if files:
        folder = name or runs.eval_dir_name(files, split)
        check_outputs({"name": run_dir / runs.EVAL_DIR / folder,
                       "perturb": run_dir / PERTURB_DIR / folder if perturb is not None
                       else None},
                      [*files, *([exported] if exported is not None else [])])
    result = evaluate(run_dir, files or None, split=split, name=name, latency=latency,
                      threads=threads, command=command, overwrite=overwrite,
                      exported=exported, shift_threshold_sd=shift_threshold_sd,
                      device=device)
    perturbed = None
    if perturb is not None:
        from .perturb import perturb_runs

        perturbed = perturb_runs([run_dir], files, kinds=perturb, threshold=threshold,
                                 split=split, name=name, command=command,
                                 on_level=on_level).results[0]
    from .tables import drift_warnings

    warnings = [*result.notes, *result.warnings, *drift_warnings(result)]
    seen = result.extra.get("trained_recordings") or {}
    if result.overlaps_training and split == "all":
        warnings.append(f"{', '.join(result.overlaps_training)} was used to train this run; "
                        "these metrics include training trials (use `split='test'`)")
    elif seen.get("n_trials"):
        warnings.append(
            f"{seen['n_trials']} of {seen['n_evaluated']} evaluated trial(s) were read from "
            f"source files this run was trained on (same SHA-256: "
            f"{', '.join(seen['trials'])}{' ...' if seen['n_trials'] > len(seen['trials']) else ''}"
            "): these metrics include training recordings; "
            "evaluate on recordings the run never saw")
    return EvaluateRunResult(result, perturbed, warnings)


__all__ = ["EvaluateRunResult", "default_run_dir", "epoch_line", "evaluate_run", "fold_line",
           "plan_line", "start_line", "train_summary", "train_run"]
