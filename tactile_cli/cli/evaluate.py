"""`tactile evaluate RUN --data FILE... [--split test|all] [--json]`; RUN may be a seed spread."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ._batch import BATCH_FLAGS, FileBatchPrinter, SchedulerOption, WorkersOption, finish_batch
from ._errors import Flag, run_guarded, spell
from ._options import DeviceOption, data_files
from ._output import echo_json, print_blocks, warn

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE...", "split": "--split", "threshold": "--threshold",
    "overwrite": "--overwrite", "name": "--name", "exported": "--exported FILE",
    "perturb": "--perturb", "threads": "--threads", "shift_threshold_sd": "--shift-threshold",
    "device": "--device", **BATCH_FLAGS,
}


def evaluate_command(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(
        help="Run folder written by `tactile train`, or a folder of `tactile seed-spread` made "
        "with --eval-data: every seed's model is scored on --data, with the seeds' spread.",
        show_default=False, metavar="RUN")],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d", help="Tactile HDF5 file(s) to evaluate on; repeat the option or list "
        "several files after it. A cross-validated run (train --cv) needs none: each fold is "
        "scored on its held-out trials.", show_default=False, metavar="FILE")] = None,
    split: Annotated[str, typer.Option(
        help="all: every trial; test: the trials the run's split rule puts in test (on the "
        "training files, the training's test split).")] = "all",
    name: Annotated[str | None, typer.Option(
        help="Name of the results folder RUN/eval/<name> (default from the data file names).",
        show_default=False)] = None,
    threads: Annotated[int, typer.Option(
        min=1, help="torch CPU threads for the latency measurement.")] = 1,
    latency: Annotated[bool, typer.Option(
        "--latency/--no-latency", help="Measure latency and throughput.")] = True,
    overwrite: Annotated[
        bool, typer.Option(help="Replace an existing RUN/eval/<name> folder.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print metrics.json to stdout.")] = False,
    device: DeviceOption = "auto",
    each: Annotated[bool, typer.Option(
        "--each", help="Evaluate on each --data file apart, into RUN/eval/<file stem>, one task "
        "per file on Dask (--workers, --scheduler); evaluations newer than their file and the "
        "model are skipped; no latency (tasks side by side would time each other).")] = False,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    perturb: Annotated[bool, typer.Option(
        "--perturb", help="Also re-evaluate on perturbed copies of the data (see `tactile "
        "perturb`); results in RUN/perturb/<name>/.")] = False,
    perturb_kinds: Annotated[str, typer.Option(
        "--perturb-kinds", help="Kinds for --perturb: noise, lowpass, drop, drop_events, "
        "drop_samples, scale (comma-separated).")] = "noise,lowpass,drop,scale",
    threshold: Annotated[str, typer.Option(
        help="--perturb breaking point: accuracy below a factor of the clean accuracy (0.9x) or "
        "an accuracy (0.95 or 95%).")] = "0.9x",
    exported: Annotated[Path | None, typer.Option(
        "--exported", help="A file `tactile export` wrote from this run: its outputs are checked "
        "against the run's on the same windows and its batch-1 latency (onnxruntime or "
        "TorchScript) is measured beside torch's.", metavar="FILE", show_default=False)] = None,
    shift_threshold: Annotated[float, typer.Option(
        "--shift-threshold", help="Flag a channel whose mean in the evaluated data lies more "
        "than this many training standard deviations from the training data's.", metavar="SD"
    )] = 1.0,
) -> None:
    """Evaluate a trained run: overall accuracy, per-class precision/recall/F1 and confusion
    matrix (PNG + JSON) per classification head, MAE/RMSE per regression head, latency per
    window at batch 1 and windows/s at batch 1024 on this machine, parameters and size.
    Files go to RUN/eval/<name>/. A seed-spread folder (`tactile seed-spread --eval-data`)
    has every seed's model scored so, into SPREAD/seed_S/eval/<name>/, and the seeds' mean,
    SD and spread beside the spread's own figures into SPREAD/eval/<name>/."""

    def body() -> None:
        from ..learn.pipeline import evaluate_run
        from ..learn.seed_spread import is_spread_folder

        files = data_files(data, ctx)
        if is_spread_folder(run):
            _evaluate_spread(run, files, split=split, name=name, threads=threads,
                             latency=latency, overwrite=overwrite, as_json=as_json,
                             device=device, shift_threshold=shift_threshold, others={
                                 "--each": each or None, "--perturb": perturb or None,
                                 "--exported": exported, "--scheduler": scheduler,
                                 "--workers": workers})
            return
        if each:
            _evaluate_each(run, files, split=split, overwrite=overwrite, as_json=as_json,
                           scheduler=scheduler, workers=workers, others={
                               "--name": name, "--perturb": perturb or None,
                               "--exported": exported})
            return
        if scheduler is not None or workers is not None:
            raise InputError("--scheduler and --workers go with --each (one task per file)")
        kinds = [k for k in perturb_kinds.split(",") if k.strip()] if perturb else None
        result = evaluate_run(run, files, split=split, name=name,  # type: ignore[arg-type]
                              latency=latency, threads=threads, overwrite=overwrite,
                              exported=exported, perturb=kinds, threshold=threshold,
                              shift_threshold_sd=shift_threshold, device=device)
        if as_json:
            echo_json(result.as_dict())
        else:
            from ..learn.tables import evaluation_blocks, perturbation_blocks

            print_blocks(evaluation_blocks(result.evaluation), width=120)
            if result.perturbation is not None:
                print_blocks(perturbation_blocks([result.perturbation]), width=140)
        warn(result.warnings)

    run_guarded(body, flags=FLAGS)


def _evaluate_spread(spread: Path, files: list[Path], *, split: str, name: str | None,
                     threads: int, latency: bool, overwrite: bool, as_json: bool, device: str,
                     shift_threshold: float, others: dict[str, Any]) -> None:
    """A seed-spread folder: every seed's model scored on ``files``, the seeds' spread."""
    from ..learn.spread_eval import evaluate_spread, spread_eval_summary

    for flag, value in others.items():
        if value is not None:
            raise InputError(f"{flag} goes with a run folder, not a seed spread", path=spread)
    result = evaluate_spread(spread, files, name=name, split=split, latency=latency,
                             threads=threads, overwrite=overwrite, device=device,
                             shift_threshold_sd=shift_threshold)
    if as_json:
        echo_json(result.as_dict())
    else:
        print(spread_eval_summary(result))
    warn(result.notes)


def _evaluate_each(run: Path, files: list[Path], *, split: str, overwrite: bool, as_json: bool,
                   scheduler: str | None, workers: int | None, others: dict[str, Any]) -> None:
    """``--each``: one evaluation per data file on Dask, a line per file."""
    from ..learn.evaluate_each import NO_LATENCY, describe_item, evaluate_each

    if not files:
        raise InputError("--each needs --data FILE...: the files to evaluate on apart")
    for flag, value in others.items():
        if value is not None:
            raise InputError(f"{flag} goes with one evaluation; --each names each results "
                             "folder after its data file")
    printer = FileBatchPrinter("evaluate", describe=describe_item, todo="to evaluate",
                               flags=lambda t: spell(t, FLAGS))
    with printer.running():
        result = evaluate_each(run, files, split=split,  # type: ignore[arg-type]
                               overwrite=overwrite, scheduler=scheduler, workers=workers,
                               on_plan=printer.on_plan, on_progress=printer.on_progress,
                               on_item=printer.on_item)
    if not as_json:
        print(f"tactile: note: {NO_LATENCY}", file=sys.stderr)
    finish_batch(result, as_json=as_json, payload={"note": NO_LATENCY})
