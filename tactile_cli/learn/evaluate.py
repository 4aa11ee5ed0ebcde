"""``tactile evaluate``: metrics, confusion matrices and latency of a trained run.

For every classification head: overall accuracy, per-class precision, recall and F1 (the
form of paper 000, Table I), macro F1, the confusion matrix (rows true, columns
predicted), and, for per-sample labels, the accuracy without the windows whose target
lies within ``boundary_margin`` samples of a label change (a causal window at a
transition is ambiguous for a sample or two; the plain accuracy stays the headline). For
every regression head: MAE and RMSE in the label's own units. Cost on this machine:
latency per window at batch 1 (median, 95th percentile), windows per second at a large
batch, parameter count and model size.

The data must be data of the run's input (:mod:`.inputs`): the same sample period within
0.1 %, channels and units, else an error; a run whose run.json predates that record is
evaluated with a note saying the period was not checked.

Results go to ``RUN/eval/<name>/`` (see :mod:`.runs`): ``metrics.json`` (format
``tactile-eval`` 1; the fields later commands read: ``accuracy``, ``heads``,
``latency``, ``model``, ``input``), a PNG and a JSON confusion matrix per classification
head and ``predictions.csv`` (one row per window).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from ..errors import InputError
from ..store.origin import data_origin
from ..store.provenance import current_command, utc_now
from . import runs
from .cv import evaluate_cv
from .data import (
    check_heads_match,
    data_files,
    make_windows,
    read_trials,
    trial_groups,
    windowless_note,
)
from .device import resolve_device
from .drift import SHIFT_THRESHOLD_SD, input_shift, interleaving
from .inputs import checked_input, input_record
from .metrics import (
    ClassificationMetrics,
    ClassMetrics,
    EvalResult,
    RegressionMetrics,
    check_eval_folder,
    classification_metrics,
    data_records,
    head_metrics,
    measure_latency_of,
    overlaps,
    regression_metrics,
    support_warnings,
    write_eval,
)
from .models import count_parameters, state_size_bytes
from .splits import held_out_trials
from .train import predict_on


def evaluate(
    run_dir: str | Path,
    data_paths: Sequence[str | Path] | None,
    *,
    split: Literal["all", "test"] = "all",
    name: str | None = None,
    latency: bool = True,
    threads: int | None = None,
    command: str | None = None,
    overwrite: bool = False,
    exported: str | Path | None = None,
    shift_threshold_sd: float = SHIFT_THRESHOLD_SD,
    device: str = "auto",
) -> EvalResult:
    """Evaluate a run on data files and write ``RUN/eval/<name>/`` (an existing evaluation
    of that name is an error unless ``overwrite``; the folder is written atomically).

    ``split="test"`` keeps the trials the run held out for test (its ``split.csv``; for
    trials the run never saw, those its split rule puts in test); ``"all"`` uses every
    trial. ``threads`` (default 1) is the torch thread count of the latency measurement.
    Data of another sample period (more than 0.5 %; above 0.1 % a note), other channels or
    units than the run was trained on are refused (:func:`.inputs.check_input`). A
    cross-validated run (``tactile train --cv``) is evaluated fold by fold on its held-out trials
    (:func:`tactile_cli.learn.cv.evaluate_cv`); ``data_paths`` may then be None (the
    run's own data).

    ``exported``: a file ``tactile export`` wrote from this run; its outputs on the same
    windows are compared with the run's and its batch-1 latency (onnxruntime or TorchScript)
    is measured beside torch's (metrics.json key ``exported``, :func:`.export.check_exported`).

    Beside the metrics, metrics.json records the input shift of the evaluated trials against
    the training split per channel (key ``shift``; channels beyond ``shift_threshold_sd``
    training standard deviations flagged) and whether they are interleaved in recording
    order with the trials the run learned from (key ``interleaving``; :mod:`.drift`).

    ``device``: where the model predicts (``auto``, ``cpu`` or ``cuda``; :mod:`.device`),
    recorded in metrics.json ``device``; latency is always measured on the CPU.
    """
    if not (math.isfinite(shift_threshold_sd) and shift_threshold_sd > 0):
        raise InputError(f"`shift_threshold_sd` must be a number > 0, got {shift_threshold_sd}")
    dev = resolve_device(device)
    info = runs.read_run_info(Path(run_dir))
    if info.get("cv") is not None:
        if exported is not None:
            raise InputError("`exported` needs one model: give a fold's folder "
                             "(RUN/folds/fold_00) of the cross-validated run", path=run_dir)
        return evaluate_cv(run_dir, data_paths, name=name, latency=latency, threads=threads,
                           command=command, overwrite=overwrite, split=split,
                           shift_threshold_sd=shift_threshold_sd, device=device)
    if not data_paths:
        raise InputError("no data files; give `data_paths`")
    run = runs.load_run(run_dir)
    paths = data_files(data_paths)
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    name = name or runs.eval_dir_name(paths, split)
    out_dir = check_eval_folder(run.path, name, overwrite)
    cfg = run.config
    trials = read_trials(paths, cfg.data, trained=True)
    spec, notes = checked_input(trials, cfg.data.stream, run.input, run.path)
    check_heads_match(run.heads, trials, stream=cfg.data.stream)
    if split == "test":
        trials = held_out_trials(trials, split_csv=run.path / runs.SPLIT_CSV, split=cfg.data.split,
                             seed=cfg.seed, targets=cfg.data.targets)
        if not trials:
            raise InputError("no trial of these files is in the test split (the run's config "
                             f"has test_fraction {cfg.data.split.test_fraction}); use "
                             "`split='all'` for data the run never saw")
    ws = make_windows(trials, cfg.data, run.heads, run.normalisation)
    if len(ws) == 0:
        raise InputError(f"the data give no windows (window {cfg.data.window} samples); "
                         "are the trials shorter than the window?")
    notes = [*notes, *windowless_note(trials, ws, cfg.data.window)]
    model = run.load_model()
    outputs, used = predict_on(model, ws, dev)
    grouped = trial_groups(trials, cfg.data)
    metrics, decoded = head_metrics(run.heads, outputs, ws, run.normalisation.targets,
                                    cfg.data.boundary_margin,
                                    None if grouped is None else (cfg.data.decide_by, grouped))
    lat = measure_latency_of(model, ws, threads) if latency else None
    extra: dict[str, Any] = {
        "shift": input_shift(trials, cfg.data, run.normalisation,
                             threshold_sd=shift_threshold_sd).as_dict(),
        "interleaving": interleaving(trials, run.info.get("recording_order")).as_dict(),
        "device": used,
        "trained_recordings": trained_recordings(trials, run.info),
    }
    if exported is not None:
        from .export import check_exported, raw_windows

        extra["exported"] = check_exported(exported, run, model, ws, raw_windows(trials, run),
                                           latency=latency, threads=threads)
    result = EvalResult(
        run=str(run.path), family=cfg.model.family, name=name, split=split,
        data=data_records(paths, trials), overlaps_training=overlaps(paths, run.info),
        n_trials=len(trials), n_windows=len(ws), heads=metrics,
        n_params=count_parameters(model), size_mb=state_size_bytes(model) / 1e6,
        file_size_bytes=run.weights_path.stat().st_size, latency=lat,
        out_dir=out_dir, command=command if command is not None else current_command(),
        created_utc=utc_now(), input=input_record(spec, run.input), notes=notes,
        origin=data_origin(paths), extra=extra,
    )
    write_eval(result, run.heads, ws, decoded, run.normalisation.targets, overwrite=overwrite)
    return result


def trained_recordings(trials: Sequence[Any], info: dict[str, Any]) -> dict[str, Any] | None:
    """How many evaluated trials were read from a source file the run trained on (run.json
    ``trained_sources_sha256``): the same recordings in any tactile file, not only the
    training file itself. None for a run that records no sources (older runs)."""
    from ..store.reader import trial_source_hashes

    trained = info.get("trained_sources_sha256")
    if not isinstance(trained, list):
        return None
    known = set(map(str, trained))
    by_file: dict[str, dict[str, frozenset[str]]] = {}
    hits = []
    for t in trials:
        if t.file not in by_file:
            by_file[t.file] = trial_source_hashes(t.file)
        if by_file[t.file].get(t.trial, frozenset()) & known:
            hits.append(t.key)
    return {"n_trials": len(hits), "n_evaluated": len(trials), "trials": hits[:5]}


__all__ = ["ClassMetrics", "ClassificationMetrics", "EvalResult", "RegressionMetrics",
           "check_eval_folder", "classification_metrics", "data_records", "evaluate",
           "head_metrics", "measure_latency_of", "overlaps", "regression_metrics",
           "support_warnings", "write_eval"]
