"""``tactile train``: fit a network of the registry to windows of tactile HDF5 files.

:func:`train` validates, reads the data (:mod:`.data`), splits by trial, takes the
normalisation from the training split, trains with early stopping on the validation
split and writes a run folder (:mod:`.runs`). Seeded and deterministic on the CPU: the
seed fixes the split, the initial weights, the batch order and dropout;
``torch.use_deterministic_algorithms(True)`` and a fixed thread count make two runs with
the same seed, data and machine give identical weights (the previous torch settings are
restored afterwards).
"""

from __future__ import annotations

import copy
import csv
import math
import platform
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from .._version import __version__
from ..errors import InputError
from ..interrupt import raise_if_requested
from ..store.outdir import check_output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .config import CLASSIC_FAMILIES, TrainConfig
from .data import (
    Normalisation,
    TrialSeries,
    WindowSet,
    class_weights,
    data_files,
    fit_normalisation,
    make_windows,
    read_trials,
    regression_stats,
    resolve_channels,
    resolve_heads,
    trial_groups,
)
from .device import device_name, resolve_device
from .drift import recording_record
from .figures import plot_curves
from .heads import HeadSpec, primary_head
from .inputs import InputSpec, input_spec, period_notes
from .models import MultiTaskNet, build_model, count_parameters, multitask_loss, state_size_bytes
from .preprocess import augment_windows
from .sensor_unit import sensor_unit_record
from .splits import SplitAssignment, assign_splits, default_by, split_from_mapping


@dataclass(frozen=True)
class EpochRecord:
    """One epoch: mean training loss, validation loss and primary-head accuracy (NaN
    without a validation split), wall seconds, and whether it is the best so far."""

    epoch: int
    train_loss: float
    val_loss: float
    val_accuracy: float
    seconds: float
    best: bool

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Prepared:
    """Trials, split, heads, normalisation and windows of one training data set, and the
    input (stream, sample period, channels, units) every trial shares."""

    trials: list[TrialSeries]
    assignment: SplitAssignment
    heads: list[HeadSpec]
    normalisation: Normalisation
    windows: dict[str, WindowSet]  # split -> windows
    input: InputSpec
    notes: list[str] = field(default_factory=list)  # trials at a rate accepted, not the same


@dataclass
class TrainResult:
    """What ``tactile train`` reports; the run folder holds the rest."""

    run_dir: Path
    family: str
    history: list[EpochRecord]
    best_epoch: int
    stopped_early: bool
    n_params: int
    size_mb: float
    wall_time_s: float
    train_time_s: float
    threads: int
    n_trials: dict[str, int]
    n_windows: dict[str, int]
    best_val_loss: float
    best_val_accuracy: float
    heads: list[HeadSpec] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    device: str = "cpu"
    """Where the network trained (:mod:`.device`): ``cpu`` or ``cuda (<GPU name>)``."""

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["run_dir"] = str(self.run_dir)
        out["history"] = [h.as_dict() for h in self.history]
        out["heads"] = [h.as_dict() for h in self.heads]
        return out


@contextmanager
def deterministic(seed: int, threads: int) -> Iterator[None]:
    """Seed torch, turn on deterministic algorithms and fix the CPU thread count; restore
    the previous settings on exit."""
    previous = (torch.are_deterministic_algorithms_enabled(), torch.get_num_threads())
    torch.manual_seed(seed)
    torch.use_deterministic_algorithms(True)
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(previous[0])
        torch.set_num_threads(previous[1])


@dataclass(frozen=True)
class GivenSplits:
    """Splits decided outside the config: ``mapping`` is ``file name/trial`` (or a trial
    name unique in the data) -> train/val/test; ``source`` names where they come from (a
    ``--split-from`` CSV, a cross-validation fold), ``mode`` how run.json records them."""

    mapping: Mapping[str, str]
    source: str
    mode: str = "given"


def prepare(config: TrainConfig, data_paths: Sequence[Path], *,
            given: GivenSplits | None = None) -> Prepared:
    """Read, split, normalise (training split only) and window the training data; every
    trial must have the same sample period (within 0.5 %, a note above 0.1 %) and channel
    units. ``given``: splits from outside the config (else the config's ``data.split``
    rule)."""
    d = config.data
    trials = read_trials(data_paths, d)
    trial_groups(trials, d)  # a trial without the decide_by label: refused before training
    spec = input_spec(trials, d.stream)
    if given is not None:
        assignment = split_from_mapping(trials, given.mapping, source=given.source,
                                        mode=given.mode)
    else:
        assignment = assign_splits(trials, d.split, config.seed,
                                   by=default_by(d.split, d.targets))
    heads = resolve_heads(d.targets, trials)
    by_split = {s: [trials[i] for i in assignment.indices(s)] for s in ("train", "val", "test")}
    if not by_split["train"]:
        raise InputError("no trial is in the train split (split attributes: "
                         f"{assignment.counts()}); set data.split.mode: random")
    norm = fit_normalisation(by_split["train"], d.channels, enabled=d.normalise,
                             transform=d.transform, baseline=d.baseline)
    train_ws = make_windows(by_split["train"], d, heads, norm)
    if len(train_ws) == 0:
        raise InputError(f"the training trials give no windows (window {d.window} samples, "
                         f"pad {d.pad}); use a shorter data.window or data.pad: zero")
    norm.targets = regression_stats(train_ws, heads)
    for name, (m, s) in norm.targets.items():
        train_ws.targets[name] = ((train_ws.targets[name] - m) / s).astype(np.float32)
    windows = {"train": train_ws}
    for s in ("val", "test"):
        windows[s] = make_windows(by_split[s], d, heads, norm)
    notes = period_notes(trials, spec.sample_period_s, "the first trial's")
    return Prepared(trials, assignment, heads, norm, windows, spec, notes)


def trained_sources(trials: Sequence[TrialSeries], splits: Sequence[str]) -> list[str]:
    """The SHA-256 of every source file of the train and validation trials (sorted)."""
    from ..store.reader import trial_source_hashes

    by_file: dict[str, dict[str, frozenset[str]]] = {}
    out: set[str] = set()
    for t, split in zip(trials, splits, strict=True):
        if split in ("train", "val"):
            if t.file not in by_file:
                by_file[t.file] = trial_source_hashes(t.file)
            out |= by_file[t.file].get(t.trial, frozenset())
    return sorted(out)


def batch_targets(ws: WindowSet, idx: np.ndarray) -> dict[str, torch.Tensor]:
    return {k: torch.from_numpy(np.ascontiguousarray(v[idx])) for k, v in ws.targets.items()}


#: torch CPU threads of :func:`predict`, whatever the caller's (see there)
PREDICT_THREADS = 1


def predict(model: nn.Module, ws: WindowSet, *, batch_size: int = 4096,
            device: torch.device | None = None) -> dict[str, np.ndarray]:
    """Raw outputs (logits or standardised values) of every window: head -> (n, k) / (n,).

    Bit-identical whatever the process's torch thread count (a Dask worker runs with one,
    ``workers=0`` and a plain ``evaluate`` with the machine's cores): torch splits a
    layer's reductions by its intra-op thread count, which changes the last bit of some
    outputs, so every batch of ``batch_size`` windows runs on :data:`PREDICT_THREADS`
    thread(s) and the caller's count is restored afterwards. ``device``: where the model
    is (:mod:`.device`; default the CPU), the batches go there and the outputs come back."""
    model.eval()
    outs: dict[str, list[np.ndarray]] = {}
    previous = torch.get_num_threads()
    torch.set_num_threads(PREDICT_THREADS)
    try:
        with torch.inference_mode():
            for lo in range(0, len(ws), batch_size):
                idx = np.arange(lo, min(lo + batch_size, len(ws)))
                batch = torch.from_numpy(ws.windows(idx))
                if device is not None and device.type != "cpu":
                    batch = batch.to(device)
                for k, v in model(batch).items():
                    outs.setdefault(k, []).append(v.cpu().numpy())
    finally:
        torch.set_num_threads(previous)
    return {k: np.concatenate(v) for k, v in outs.items()}


def predict_on(model: Any, ws: Any, device: Any) -> tuple[dict[str, np.ndarray], str]:
    """The outputs of :func:`.train.predict` on ``device`` (a network; a classic family and
    the CPU predict as before), the model back on the CPU afterwards, and the device's
    name."""
    if device.type == "cpu" or not isinstance(model, torch.nn.Module) \
            or getattr(model, "n_parameters", None) is not None:
        return predict(model, ws), "cpu"
    model.to(device)
    try:
        return predict(model, ws, device=device), device_name(device)
    finally:
        model.cpu()


def _validate(model: nn.Module, ws: WindowSet, heads: Sequence[HeadSpec],
              weights: dict[str, torch.Tensor] | None, batch_size: int,
              device: torch.device) -> tuple[float, float]:
    """(loss, primary-head accuracy) on a window set; NaN when it is empty."""
    if len(ws) == 0:
        return math.nan, math.nan
    outputs = {k: torch.from_numpy(v) for k, v in predict(model, ws, batch_size=batch_size,
                                                          device=device).items()}
    if weights is not None and device.type != "cpu":
        weights = {k: v.cpu() for k, v in weights.items()}
    targets = batch_targets(ws, np.arange(len(ws)))
    with torch.inference_mode():
        loss = float(multitask_loss(outputs, targets, heads, weights).total)
    head = primary_head(heads)
    acc = math.nan
    if head is not None:
        acc = float((outputs[head.name].argmax(dim=1) == targets[head.name]).double().mean())
    return loss, acc


def _set_feature_stats(model: MultiTaskNet, ws: WindowSet, norm: Normalisation) -> None:
    """MLP: standardise the summary features with training-window statistics."""
    summary = getattr(model.trunk, "summary", None)
    if summary is None:
        return
    feats = []
    with torch.inference_mode():
        for lo in range(0, len(ws), 8192):
            idx = np.arange(lo, min(lo + 8192, len(ws)))
            feats.append(summary.raw(torch.from_numpy(ws.windows(idx))).double())
    f = torch.cat(feats)
    mean, std = f.mean(dim=0), f.std(dim=0, correction=0)
    # a feature constant up to float rounding (the std of z-scored windows: 1 +- 1e-7) is
    # constant: dividing by that spread would blow the rounding up into large inputs
    varies = torch.isfinite(std) & (std > 1e-5 * mean.abs().clamp(min=1.0))
    std = torch.where(varies, std, torch.ones_like(std))
    summary.feature_mean.copy_(mean.float())
    summary.feature_std.copy_(std.float())
    norm.features = {"names": list(summary.features), "mean": mean.tolist(),
                     "std": std.tolist()}


def train(
    config: TrainConfig,
    data_paths: Sequence[str | Path],
    out: str | Path,
    *,
    config_path: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    on_start: Callable[[Prepared], None] | None = None,
    given: GivenSplits | None = None,
    device: str = "auto",
) -> TrainResult:
    """Train ``config`` on ``data_paths`` and write the run folder ``out``.

    ``on_start`` is called once the data are ready, ``on_epoch`` after every epoch (for
    progress display); ``given``: splits from a CSV or a cross-validation fold instead of
    the config's rule. Channel patterns of the config (``ele*``) are resolved against the
    data and the resolved names saved. ``device``: ``auto``, ``cpu`` or ``cuda``
    (:mod:`.device`; recorded in run.json ``training.device``; a classic family always
    runs on the CPU). Returns the summary; raises :class:`InputError` for bad data.
    """
    dev = resolve_device(device)
    if config.model.family in CLASSIC_FAMILIES:  # scikit-learn, stored as ONNX (issue 34)
        from .classic import train_classic

        return train_classic(config, data_paths, out, config_path=config_path,
                             overwrite=overwrite, command=command, on_epoch=on_epoch,
                             on_start=on_start, given=given)
    started = time.perf_counter()
    out = Path(out)
    if out.exists() and out.is_dir() and not overwrite:
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    check_output_folder(out, overwrite=overwrite)  # a file at `out` or a parent: before work
    paths = data_files(data_paths)
    config = config.model_copy(update={"data": resolve_channels(config.data, paths)})
    opt_cfg = config.optim
    threads = opt_cfg.threads
    with deterministic(config.seed, threads):
        prep = prepare(config, paths, given=given)
        if on_start is not None:
            on_start(prep)
        d = config.data
        torch.manual_seed(config.seed)
        model = build_model(config.model, window=d.window, n_channels=len(d.channels),
                            heads=prep.heads, frames=d.frames)
        train_ws, val_ws = prep.windows["train"], prep.windows["val"]
        _set_feature_stats(model, train_ws, prep.normalisation)
        weights = None
        if d.class_weights:
            weights = {h.name: torch.tensor(class_weights(train_ws.targets[h.name],
                                                          len(h.classes)), dtype=torch.float32)
                       for h in prep.heads if h.kind == "classification"}
        on_gpu = dev.type != "cpu"
        if on_gpu:
            model.to(dev)
        dev_weights = None if weights is None or not on_gpu else \
            {k: v.to(dev) for k, v in weights.items()}
        if opt_cfg.optimizer == "adam":
            optim: torch.optim.Optimizer = torch.optim.Adam(
                model.parameters(), lr=opt_cfg.lr, weight_decay=opt_cfg.weight_decay)
        else:
            optim = torch.optim.SGD(model.parameters(), lr=opt_cfg.lr,
                                    momentum=opt_cfg.momentum,
                                    weight_decay=opt_cfg.weight_decay)
        schedule = None
        if opt_cfg.lr_schedule == "cosine":
            schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optim, T_max=opt_cfg.epochs)
        gen = torch.Generator().manual_seed(config.seed)
        # augmentation draws come from their own stream, so turning it on leaves the batch
        # order and the initial weights of the same seed unchanged
        aug_rng = np.random.default_rng([config.seed, 34]) if d.augment.active else None
        history: list[EpochRecord] = []
        best_state = copy.deepcopy(model.state_dict())
        best_epoch, best_score, since_best = 0, math.inf, 0
        stopped_early = False
        train_started = time.perf_counter()
        n = len(train_ws)
        for epoch in range(1, opt_cfg.epochs + 1):
            raise_if_requested()
            t0 = time.perf_counter()
            model.train()
            order = torch.randperm(n, generator=gen).numpy()
            total = 0.0
            for lo in range(0, n, opt_cfg.batch_size):
                idx = order[lo:lo + opt_cfg.batch_size]
                if aug_rng is None:
                    batch = train_ws.windows(idx)
                else:
                    batch = train_ws.normalise(augment_windows(train_ws.raw_windows(idx),
                                                               d.augment, aug_rng))
                if on_gpu:
                    outputs = model(torch.from_numpy(batch).to(dev))
                    loss = multitask_loss(
                        outputs, {k: v.to(dev) for k, v in batch_targets(train_ws, idx).items()},
                        prep.heads, dev_weights).total
                else:
                    outputs = model(torch.from_numpy(batch))
                    loss = multitask_loss(outputs, batch_targets(train_ws, idx), prep.heads,
                                          weights).total
                optim.zero_grad(set_to_none=True)
                loss.backward()
                if opt_cfg.grad_clip:
                    nn.utils.clip_grad_norm_(model.parameters(), opt_cfg.grad_clip)
                optim.step()
                total += float(loss.detach()) * idx.shape[0]
            if not math.isfinite(total):
                raise InputError(f"training diverged in epoch {epoch} (the loss is not finite); "
                                 "lower optim.lr or set optim.grad_clip")
            if schedule is not None:
                schedule.step()
            val_loss, val_acc = _validate(model, val_ws, prep.heads, weights,
                                          opt_cfg.batch_size * 8, dev)
            if len(val_ws) == 0:
                score = -epoch  # no validation: the last epoch is the best
            elif opt_cfg.monitor == "val_loss":
                score = val_loss
            else:
                score = -val_acc
            improved = score < best_score or (best_epoch == 0 and not math.isfinite(score))
            if improved:
                best_score, best_epoch, since_best = score, epoch, 0
                best_state = copy.deepcopy(model.state_dict())
            else:
                since_best += 1
            record = EpochRecord(epoch, total / n, val_loss, val_acc, time.perf_counter() - t0,
                                 improved)
            history.append(record)
            if on_epoch is not None:
                on_epoch(record)
            if opt_cfg.patience and len(val_ws) and since_best >= opt_cfg.patience:
                stopped_early = epoch < opt_cfg.epochs
                break
        train_time = time.perf_counter() - train_started
        model.load_state_dict(best_state)
        if on_gpu:  # the run folder holds CPU weights, loadable anywhere
            model.cpu()
        model.eval()

    best = history[best_epoch - 1]
    n_params = count_parameters(model)
    size_mb = state_size_bytes(model) / 1e6
    n_trials = prep.assignment.counts()
    n_windows = {s: len(ws) for s, ws in prep.windows.items()}
    info = {
        "format": runs.RUN_FORMAT,
        "format_version": runs.RUN_FORMAT_VERSION,
        "created_utc": utc_now(),
        "command": command if command is not None else current_command(),
        "config_file": None if config_path is None else str(config_path),
        "versions": {"tactile": __version__, "torch": torch.__version__,
                     "numpy": np.__version__, "python": platform.python_version(),
                     "platform": platform.platform()},
        "seed": config.seed,
        "data": [{"path": str(p), "sha256": sha256_of(p), "size_bytes": p.stat().st_size,
                  "n_trials": sum(1 for t in prep.trials if t.file == str(p))} for p in paths],
        "heads": [h.as_dict() for h in prep.heads],
        "input": prep.input.as_dict(),
        "sensor_unit": sensor_unit_record(paths, d.stream),
        # the source files (SHA-256) of the trials it learned from: `evaluate` finds them in
        # any file, not only this one (the same recordings ingested again, or with others)
        "trained_sources_sha256": trained_sources(prep.trials, prep.assignment.splits),
        "recording_order": recording_record(
            [t for t, s in zip(prep.trials, prep.assignment.splits, strict=True)
             if s in ("train", "val")], prep.heads, split_mode=d.split.mode,
            split_by=d.split.by),
        "class_weights": None if weights is None else {k: v.tolist()
                                                       for k, v in weights.items()},
        "split": {"mode": prep.assignment.mode, "by": prep.assignment.by,
                  "source": None if given is None else given.source,
                  "trials": n_trials, "windows": n_windows,
                  "warnings": [*prep.assignment.warnings, *prep.notes]},
        "model": {"family": config.model.family, "n_params": n_params, "size_mb": size_mb,
                  "window": d.window, "channels": list(d.channels), "stream": d.stream},
        "training": {"epochs_run": len(history), "best_epoch": best_epoch,
                     "stopped_early": stopped_early, "monitor": opt_cfg.monitor,
                     "best_val_loss": best.val_loss, "best_val_accuracy": best.val_accuracy,
                     "train_time_s": train_time, "threads": threads, "deterministic": True,
                     "device": device_name(dev), "device_requested": device},
    }
    rows = [r.as_dict() for r in history]

    def fill(tmp: Path) -> None:
        torch.save(model.state_dict(), tmp / runs.MODEL_PT)
        (tmp / runs.CONFIG_YAML).write_text(config.as_yaml(), encoding="utf-8")
        (tmp / runs.NORMALISATION_JSON).write_text(prep.normalisation.to_json() + "\n",
                                                   encoding="utf-8")
        with open(tmp / runs.HISTORY_CSV, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        plot_curves(rows, tmp / runs.CURVES_PNG, best_epoch=best_epoch,
                    title=f"{config.model.family}: {out.name}")
        with open(tmp / runs.SPLIT_CSV, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(["file", "trial", "split"])
            for t, s in zip(prep.trials, prep.assignment.splits, strict=True):
                writer.writerow([t.file, t.trial, s])
        info["wall_time_s"] = time.perf_counter() - started
        runs.write_json(tmp / runs.RUN_JSON, info)

    runs.write_folder(out, fill, overwrite=overwrite)
    return TrainResult(
        run_dir=out, family=config.model.family, history=history, best_epoch=best_epoch,
        stopped_early=stopped_early, n_params=n_params, size_mb=size_mb,
        wall_time_s=float(info["wall_time_s"]), train_time_s=train_time, threads=threads,
        n_trials=n_trials, n_windows=n_windows, best_val_loss=best.val_loss,
        best_val_accuracy=best.val_accuracy, heads=prep.heads,
        warnings=[*prep.assignment.warnings, *prep.notes], device=device_name(dev),
    )


__all__ = ["EpochRecord", "GivenSplits", "Prepared", "TrainResult", "batch_targets",
           "deterministic", "predict", "predict_on", "prepare", "train"]
