"""Cross-validation: ``tactile train --cv K|loto`` and the evaluation of such a run.

A cross-validated run folder (format ``tactile-run`` 1 with a ``cv`` record)::

    RUN/
      run.json               as a plain run's, plus ``cv``: k, mode, label, the held-out
                             trials of every fold and each fold's training summary;
                             ``model`` and ``input`` are fold 0's (every fold has the same
                             architecture and input)
      config.resolved.yaml   the config, channel patterns resolved
      folds/fold_00/ ...     one complete run folder per fold (:mod:`.runs`): the fold's
                             held-out trials are its ``test`` split; its validation trials
                             come from its training trials (``data.split.val_fraction``)
      eval/<name>/           ``tactile evaluate RUN``: every fold's model on its own
                             held-out trials, pooled

The folds come from :func:`.splits.cv_folds` (k-fold random, stratified or grouped as the
config's ``data.split`` says, or leave-one-trial-out). Folds are trained in parallel
processes when ``jobs`` > 1 (each with the config's ``optim.threads``) and written one by
one into ``.RUN.cv-partial/`` beside the run; a stopped run resumes there, skipping folds
already finished, and the folder becomes ``RUN`` only when every fold is done.

The evaluation reports the pooled metrics (every held-out window once, so the confusion
matrix sums to the data), the per-fold accuracy and macro F1 with their mean and standard
deviation over folds (ddof 1), bootstrap intervals over trials and per-trial votes
(:mod:`.trial_metrics`).
"""

from __future__ import annotations

import hashlib
import json
import math
import multiprocessing
import os
import platform
import shutil
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch

from .._version import __version__
from ..errors import InputError
from ..interrupt import raise_if_requested
from ..store.atomic import (
    remove_stale_temporaries,
    swap_into_place,
    write_error,
    write_text,
)
from ..store.origin import data_origin
from ..store.outdir import check_output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .config import TrainConfig, parse_config
from .data import (
    WindowSet,
    check_heads_match,
    data_files,
    make_windows,
    read_trials,
    resolve_channels,
    trial_groups,
    windowless_note,
)
from .device import resolve_device
from .drift import (
    SHIFT_THRESHOLD_SD,
    input_shift,
    interleaving,
    pooled_interleaving,
    pooled_shift,
)
from .heads import primary_head
from .inputs import checked_input, input_record
from .metrics import (
    EvalResult,
    check_eval_folder,
    classification_metrics,
    data_records,
    head_metrics,
    measure_latency_of,
    write_eval,
)
from .models import count_parameters, state_size_bytes
from .splits import FoldPlan, cv_folds, default_by
from .train import GivenSplits, predict_on, train
from .trial_metrics import trial_votes

FOLDS_DIR = "folds"
PLAN_JSON = "cv_plan.json"


def fold_name(index: int) -> str:
    return f"fold_{index:02d}"


def partial_dir(out: Path) -> Path:
    """Where a cross-validation under way keeps its finished folds."""
    return out.with_name(f".{out.name}.cv-partial")


def parse_cv(value: str | int) -> int | str:
    """``--cv`` value: an integer >= 2 (k-fold) or ``loto``."""
    text = str(value).strip().lower()
    if text == "loto":
        return "loto"
    try:
        k = int(text)
    except ValueError:
        raise InputError(f"`k` must be an integer >= 2 or loto, got {value!r}") from None
    if k < 2:
        raise InputError(f"`k` must be an integer >= 2 or loto, got {value!r}")
    return k


def default_jobs(n_folds: int, threads: int) -> int:
    """Parallel fold processes: as many as the cores allow at ``threads`` each."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)
    return max(1, min(n_folds, cores // max(1, threads)))


@dataclass
class CvTrainResult:
    """What ``tactile train --cv`` reports; the run folder holds the rest."""

    run_dir: Path
    family: str
    k: int | str
    n_folds: int
    mode: str
    by: str | None
    resumed: list[int]
    trained: list[int]
    jobs: int
    wall_time_s: float
    warnings: list[str]
    folds: list[dict[str, Any]]

    def as_dict(self) -> dict[str, Any]:
        return {"run_dir": str(self.run_dir), "family": self.family, "k": self.k,
                "n_folds": self.n_folds, "mode": self.mode, "by": self.by,
                "resumed_folds": self.resumed, "trained_folds": self.trained,
                "jobs": self.jobs, "wall_time_s": self.wall_time_s,
                "warnings": self.warnings, "folds": self.folds}


def _plan_record(config: TrainConfig, paths: Sequence[Path], plan: FoldPlan) -> dict[str, Any]:
    return {"config_sha256": hashlib.sha256(config.as_yaml().encode()).hexdigest(),
            "data": [{"path": str(p), "sha256": sha256_of(p)} for p in paths],
            **plan.as_dict()}


def _train_fold(config_yaml: dict[str, Any], paths: list[str], fold_dir: str,
                mapping: dict[str, str], command: str, source: str, device: str = "auto"
                ) -> dict[str, Any]:
    """One fold (in a worker process or in this one): a complete run folder."""
    config = parse_config(config_yaml)
    result = train(config, paths, fold_dir, command=command,
                   given=GivenSplits(mapping, source, "cv"), device=device)
    return {"best_epoch": result.best_epoch, "epochs_run": len(result.history),
            "train_time_s": result.train_time_s, "n_trials": result.n_trials,
            "n_windows": result.n_windows, "best_val_loss": result.best_val_loss,
            "best_val_accuracy": result.best_val_accuracy,
            "notes": _fit_notes(Path(fold_dir))}


def _fit_notes(fold_dir: Path) -> list[str]:
    """What the fit of a fold's model said about itself (``training.notes`` of its
    ``run.json``: a classic family's solver that did not converge, trees that could not
    split); [] for a network."""
    info = runs.read_run_info(fold_dir)
    return [str(n) for n in info.get("training", {}).get("notes", [])]


def train_cv(
    config: TrainConfig,
    data_paths: Sequence[str | Path],
    out: str | Path,
    *,
    k: int | str,
    jobs: int | None = None,
    config_path: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    on_plan: Callable[[FoldPlan, list[int]], None] | None = None,
    on_fold: Callable[[int, dict[str, Any]], None] | None = None,
    device: str = "auto",
) -> CvTrainResult:
    """Train one model per fold and write the cross-validated run folder ``out`` (see the
    module docstring). ``on_plan(plan, finished)`` is called once the folds are known,
    ``on_fold(index, summary)`` after each fold. ``device``: where each fold trains
    (:mod:`.device`)."""
    resolve_device(device)  # `cuda` without a GPU: refused before any work
    started = time.perf_counter()
    out = Path(out)
    if out.exists() and out.is_dir() and not overwrite:
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    check_output_folder(out, overwrite=overwrite)
    paths = data_files(data_paths)
    keys = [p.name for p in paths]
    if len(set(keys)) != len(keys):
        raise InputError("two data files have the same name; cross-validation names trials "
                         "by file name and trial, so rename one", path=paths[0])
    config = config.model_copy(update={"data": resolve_channels(config.data, paths)})
    d = config.data
    trials = read_trials(paths, d)
    trial_groups(trials, d)  # a trial without the decide_by label: refused before training
    plan = cv_folds(trials, d.split, config.seed, k, by=default_by(d.split, d.targets))
    record = _plan_record(config, paths, plan)
    partial = partial_dir(out)
    finished = _resume(partial, record, overwrite)
    if on_plan is not None:
        on_plan(plan, finished)
    try:
        (partial / FOLDS_DIR).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, partial) from None
    runs.write_json(partial / PLAN_JSON, record, overwrite=True)
    command = command if command is not None else current_command()
    todo = [f for f in plan.folds if f.index not in finished]
    jobs = default_jobs(len(todo), config.optim.threads) if jobs is None else max(1, jobs)
    jobs = min(jobs, max(1, len(todo)))
    raw = config.model_dump(mode="json")
    str_paths = [str(p) for p in paths]

    def args(fold: Any) -> tuple[Any, ...]:
        mapping = {trials[i].key: s for i, s in enumerate(fold.assignment.splits)}
        return (raw, str_paths, str(partial / FOLDS_DIR / fold_name(fold.index)), mapping,
                command, f"cv fold {fold.index} of {len(plan.folds)}", device)

    summaries: dict[int, dict[str, Any]] = {}
    if jobs == 1:
        for fold in todo:
            summaries[fold.index] = _train_fold(*args(fold))
            if on_fold is not None:
                on_fold(fold.index, summaries[fold.index])
    else:
        ctx = multiprocessing.get_context("spawn")  # no fork of a process with torch threads
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            pending: dict[Future[dict[str, Any]], int] = {
                pool.submit(_train_fold, *args(f)): f.index for f in todo}
            try:
                while pending:
                    raise_if_requested()  # Ctrl-C: noticed within a poll, not after the folds
                    done, _ = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                    for fut in done:
                        index = pending.pop(fut)
                        summaries[index] = fut.result()
                        if on_fold is not None:
                            on_fold(index, summaries[index])
            except BaseException:
                _stop_pool(pool, [partial / FOLDS_DIR / fold_name(f.index) for f in todo])
                raise
    for index in finished:
        info = runs.read_run_info(partial / FOLDS_DIR / fold_name(index))
        summaries[index] = {"best_epoch": info["training"].get("best_epoch"),
                            "epochs_run": info["training"].get("epochs_run"),
                            "train_time_s": info["training"].get("train_time_s"),
                            "n_trials": info["split"].get("trials"),
                            "n_windows": info["split"].get("windows"), "resumed": True,
                            "notes": _fit_notes(partial / FOLDS_DIR / fold_name(index))}
    info = _parent_info(config, paths, plan, record, summaries, partial, command, config_path)
    info["wall_time_s"] = time.perf_counter() - started
    runs.write_json(partial / runs.RUN_JSON, info, overwrite=True)
    write_text(partial / runs.CONFIG_YAML, config.as_yaml(), overwrite=True)
    if out.exists() and not overwrite:  # appeared while we worked
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    # the finished folder becomes RUN in one rename (an earlier RUN is replaced only now);
    # until then a stop keeps every finished fold in `partial` for the next try
    swap_into_place(partial, out)
    return CvTrainResult(out, config.model.family, plan.k, len(plan.folds), plan.mode, plan.by,
                         sorted(finished), [f.index for f in todo], jobs,
                         info["wall_time_s"],
                         list(plan.warnings) + _fold_split_warnings(plan)
                         + [f"fold {i}: {note}" for i in sorted(summaries)
                            for note in summaries[i].get("notes", [])],
                         [{"fold": i, **summaries[i]} for i in sorted(summaries)])


def _fold_split_warnings(plan: FoldPlan) -> list[str]:
    """Each distinct warning of the folds' own train/validation splits, with the folds that
    gave it (a blocked split with one block left in a fold's training trials has none for
    validation, so early stopping has nothing to watch)."""
    by_text: dict[str, list[int]] = {}
    for f in plan.folds:
        for w in f.assignment.warnings:
            by_text.setdefault(w, []).append(f.index)
    return [f"fold(s) {', '.join(map(str, folds))}: {text}" + (
        " (no validation trials: patience and monitor do nothing; the last epoch is kept)"
        if "none left for val" in text else "") for text, folds in by_text.items()]


def _stop_pool(pool: ProcessPoolExecutor, fold_dirs: Sequence[Path]) -> None:
    """Stop the fold processes at once (a fold under way is lost, the finished ones stay in
    the partial folder) and remove the temporary folders they leave."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        proc.terminate()
    for proc in procs:
        proc.join(timeout=10)
    for folder in fold_dirs:
        remove_stale_temporaries(folder)


def _resume(partial: Path, record: dict[str, Any], overwrite: bool) -> list[int]:
    """Indices of the folds a stopped run of the same config, data and folds finished in
    ``partial``; a stopped run of something else is an error (or removed with
    ``overwrite``)."""
    if not partial.exists():
        return []
    plan_path = partial / PLAN_JSON
    same = False
    if plan_path.is_file():
        try:
            old = json.loads(plan_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = None
        same = isinstance(old, dict) and all(
            old.get(k) == json.loads(json.dumps(record[k]))
            for k in ("config_sha256", "data", "k", "mode", "by", "folds"))
    if not same:
        if not overwrite:
            raise InputError("a stopped cross-validation of another config, data or folds is "
                             "here; pass `overwrite=True` to discard it", path=partial)
        shutil.rmtree(partial)
        return []
    folds = partial / FOLDS_DIR
    return sorted(i for i, _ in enumerate(record["folds"])
                  if (folds / fold_name(i) / runs.RUN_JSON).is_file())


def _parent_info(config: TrainConfig, paths: Sequence[Path], plan: FoldPlan,
                 record: dict[str, Any], summaries: dict[int, dict[str, Any]], partial: Path,
                 command: str, config_path: str | Path | None) -> dict[str, Any]:
    first = runs.read_run_info(partial / FOLDS_DIR / fold_name(0))
    times = [s.get("train_time_s") or 0.0 for s in summaries.values()]
    return {
        "format": runs.RUN_FORMAT, "format_version": runs.RUN_FORMAT_VERSION,
        "created_utc": utc_now(), "command": command,
        "config_file": None if config_path is None else str(config_path),
        "versions": {"tactile": __version__, "torch": torch.__version__,
                     "numpy": np.__version__, "python": platform.python_version(),
                     "platform": platform.platform()},
        "seed": config.seed, "data": first["data"], "heads": first["heads"],
        "input": first.get("input"), "class_weights": None,
        "split": {"mode": "cv", "by": plan.by, "cv_mode": plan.mode,
                  "warnings": list(plan.warnings)},
        "model": first["model"],
        "training": {"folds": [{"fold": i, **summaries[i]} for i in sorted(summaries)],
                     "train_time_s": float(sum(times)), "threads": config.optim.threads,
                     "deterministic": True},
        "cv": {**record, "folds_dir": FOLDS_DIR},
    }


# -- evaluation --------------------------------------------------------------------------------
def _pool(parts: Sequence[WindowSet], trial_ids: Sequence[np.ndarray], keys: list[str],
          n_channels: int) -> WindowSet:
    """The windows of every fold as one set for metrics and predictions (no samples:
    ``x`` is empty and ``windows()`` is not for it); trial indices point into ``keys``."""
    def cat(get: Callable[[WindowSet], np.ndarray], dtype: Any) -> np.ndarray:
        arrays = [get(p) for p in parts]
        return np.concatenate(arrays).astype(dtype) if arrays else np.zeros(0, dtype)

    heads = list(parts[0].targets) if parts else []
    near = list(parts[0].near_boundary) if parts else []
    n = sum(len(p) for p in parts)
    return WindowSet(
        x=np.zeros((0, n_channels), np.float32), starts=np.zeros(n, np.int64),
        window=parts[0].window if parts else 1,
        targets={h: np.concatenate([p.targets[h] for p in parts]) for h in heads},
        trial_index=np.concatenate(trial_ids) if trial_ids else np.zeros(0, np.int64),
        end_index=cat(lambda p: p.end_index, np.int64),
        target_index=cat(lambda p: p.target_index, np.int64),
        target_t_s=cat(lambda p: p.target_t_s, np.float64),
        near_boundary={h: np.concatenate([p.near_boundary[h] for p in parts]) for h in near},
        trials=keys,
        label_changes={h: any(p.label_changes.get(h, False) for p in parts) for h in near})


def _fold_scores(heads: Sequence[Any], ws: WindowSet, outputs: dict[str, np.ndarray]
                 ) -> dict[str, Any]:
    head = primary_head(heads)
    out: dict[str, Any] = {"n_windows": len(ws),
                           "n_trials": int(np.unique(ws.trial_index).shape[0])}
    if head is None:
        return out
    pred = outputs[head.name].argmax(axis=1)
    m = classification_metrics(ws.targets[head.name], pred, head.classes, head=head.name)
    out.update(accuracy=m.accuracy, macro_f1=m.macro_f1)
    if head.source == "trial":
        votes = trial_votes(ws.targets[head.name], outputs[head.name], ws.trial_index)
        out["per_trial_accuracy"] = None if votes is None else votes.majority_accuracy
    return out


def _split_groups(folds: Sequence[dict[str, Any]], keys: Sequence[str], groups: Sequence[str],
                  by: str | None) -> list[str]:
    """A note when trials of one ``decide_by`` group are held out in different folds (the
    group's decision then mixes models, and its trials trained each other's folds)."""
    group_of = dict(zip(keys, groups, strict=True))
    folds_of: dict[str, set[int]] = {}
    for fold in folds:
        for k in fold["test"]:
            if k in group_of:
                folds_of.setdefault(group_of[k], set()).add(int(fold["fold"]))
    split = sorted(g for g, f in folds_of.items() if len(f) > 1)
    if not split:
        return []
    return [f"{len(split)} group(s) of decide_by {by!r} have trials in several folds ("
            f"{', '.join(split[:3])}{', ...' if len(split) > 3 else ''}): their trials trained "
            "each other's models; split by the same label or a coarser one"]


def _spread(folds: Sequence[dict[str, Any]], key: str) -> dict[str, float | None]:
    values = np.array([f[key] for f in folds if f.get(key) is not None
                       and math.isfinite(f[key])], dtype=np.float64)
    return {f"{key}_mean": float(values.mean()) if values.size else None,
            f"{key}_std": float(values.std(ddof=1)) if values.size > 1 else None}


def evaluate_cv(
    run_dir: str | Path,
    data_paths: Sequence[str | Path] | None,
    *,
    name: str | None = None,
    latency: bool = True,
    threads: int | None = None,
    command: str | None = None,
    overwrite: bool = False,
    split: Literal["all", "test"] = "all",
    shift_threshold_sd: float = SHIFT_THRESHOLD_SD,
    device: str = "auto",
) -> EvalResult:
    """Evaluate every fold's model on its held-out trials and pool them (module docstring).
    The input shift and interleaving of :mod:`.drift` are taken fold by fold (each fold's
    held-out trials against its own training split) and pooled.

    ``data_paths``: the run's training files (default: the paths in its run.json); other
    data are refused, since the folds are defined on those trials. ``split`` is accepted for
    symmetry with :func:`.evaluate.evaluate`: a fold is always scored on its held-out trials.
    """
    dev = resolve_device(device)
    run_path = Path(run_dir)
    info = runs.read_run_info(run_path)
    cv = info["cv"]
    trained = {d["sha256"]: d["path"] for d in info["data"]}
    if data_paths:
        paths = data_files(data_paths)
        given = {sha256_of(p): p for p in paths}
        if set(given) != set(trained):
            names = ", ".join(Path(p).name for p in trained.values())
            raise InputError("a cross-validated run is evaluated on the data it was "
                             f"cross-validated on ({names}), fold by fold; give those files "
                             "(or none), "
                             "and evaluate one "
                             "fold's model on other data with `tactile evaluate RUN/folds/"
                             "fold_00 --data ...`", path=paths[0])
    else:
        paths = data_files([Path(p) for p in trained.values()])
        for p in paths:
            if sha256_of(p) not in trained:
                raise InputError("the run's data file has changed since training; give the "
                                 "original file in `data_paths`", path=p)
    name = name or f"{runs.eval_dir_name(paths, 'all')}.cv"
    out_dir = check_eval_folder(run_path, name, overwrite)
    folds_dir = run_path / cv.get("folds_dir", FOLDS_DIR)
    fold_runs = [runs.load_run(folds_dir / fold_name(f["fold"])) for f in cv["folds"]]
    first = fold_runs[0]
    cfg = first.config
    trials = read_trials(paths, cfg.data, trained=True)
    spec, notes = checked_input(trials, cfg.data.stream, first.input, first.path)
    check_heads_match(first.heads, trials, stream=cfg.data.stream)
    keys = [t.key for t in trials]
    index = {k: i for i, k in enumerate(keys)}
    parts: list[WindowSet] = []
    trial_ids: list[np.ndarray] = []
    outputs: dict[str, list[np.ndarray]] = {}
    fold_rows: list[dict[str, Any]] = []
    model0 = None
    ws0 = None
    shifts, inter = [], []
    for fold, run in zip(cv["folds"], fold_runs, strict=True):
        held = [trials[index[k]] for k in fold["test"] if k in index]
        if len(held) != len(fold["test"]):
            missing = next(k for k in fold["test"] if k not in index)
            raise InputError(f"held-out trial {missing} of fold {fold['fold']} is not in the "
                             "data", path=paths[0])
        ws = make_windows(held, run.config.data, run.heads, run.normalisation)
        notes = [*notes, *(f"fold {fold['fold']}: {n}"
                           for n in windowless_note(held, ws, run.config.data.window))]
        shifts.append(input_shift(held, run.config.data, run.normalisation,
                                  threshold_sd=shift_threshold_sd))
        inter.append(interleaving(held, run.info.get("recording_order")))
        model = run.load_model()
        out, used = predict_on(model, ws, dev)
        for h in run.heads:  # regression values back to their units, fold by fold
            if h.kind == "regression":
                m, s = run.normalisation.targets.get(h.name, (0.0, 1.0))
                out[h.name] = out[h.name].astype(np.float64) * s + m
                ws.targets[h.name] = ws.targets[h.name].astype(np.float64) * s + m
        fold_rows.append({"fold": int(fold["fold"]), **_fold_scores(run.heads, ws, out)})
        parts.append(ws)
        trial_ids.append(np.array([index[ws.trials[i]] for i in ws.trial_index], np.int64)
                         if len(ws) else np.zeros(0, np.int64))
        for k_, v in out.items():
            outputs.setdefault(k_, []).append(v)
        if model0 is None and len(ws):
            model0, ws0 = model, ws
    pooled = _pool(parts, trial_ids, keys, len(cfg.data.channels))
    if len(pooled) == 0 or model0 is None or ws0 is None:
        raise InputError(f"the held-out trials give no windows (window {cfg.data.window} "
                         "samples)", path=paths[0])
    merged = {k_: np.concatenate(v) for k_, v in outputs.items()}
    grouped = trial_groups(trials, cfg.data)
    if grouped is not None:
        notes = [*notes, *_split_groups(cv["folds"], keys, grouped, cfg.data.decide_by)]
    metrics, decoded = head_metrics(first.heads, merged, pooled, {}, cfg.data.boundary_margin,
                                    None if grouped is None else (cfg.data.decide_by, grouped))
    cv_record = {"k": cv["k"], "n_folds": len(cv["folds"]), "mode": cv["mode"], "by": cv["by"],
                 "folds": fold_rows, **_spread(fold_rows, "accuracy"),
                 **_spread(fold_rows, "macro_f1"), **_spread(fold_rows, "per_trial_accuracy"),
                 "std": "sample standard deviation over folds (ddof 1)",
                 "warnings": list(cv.get("warnings", []))}
    if split == "test":
        notes = [*notes, "a cross-validated run is always scored on each fold's held-out "
                 "trials; `split='test'` changes nothing"]
    lat = measure_latency_of(model0, ws0, threads) if latency else None
    fold_ids = [int(f["fold"]) for f in cv["folds"]]
    result = EvalResult(
        run=str(run_path), family=cfg.model.family, name=name, split="cv",
        data=data_records(paths, trials), overlaps_training=[],
        n_trials=len(trials), n_windows=len(pooled), heads=metrics,
        n_params=count_parameters(model0), size_mb=state_size_bytes(model0) / 1e6,
        file_size_bytes=first.weights_path.stat().st_size, latency=lat,
        out_dir=out_dir, command=command if command is not None else current_command(),
        created_utc=utc_now(), input=input_record(spec, first.input), notes=notes,
        cv=cv_record, origin=data_origin(paths),
        extra={"device": used, "shift": pooled_shift(shifts, fold_ids).as_dict(),
               "interleaving": pooled_interleaving(inter, fold_ids).as_dict()})
    write_eval(result, first.heads, pooled, decoded, {}, overwrite=overwrite)
    return result


__all__ = ["FOLDS_DIR", "CvTrainResult", "default_jobs", "evaluate_cv", "fold_name",
           "parse_cv", "partial_dir", "train_cv"]
