"""``tactile evaluate RUN --data FILE... --each``: one evaluation per data file, on Dask.

:func:`evaluate_each` plans one task per data file, each writing ``RUN/eval/<file
stem>[.test]/`` (the name :func:`~tactile_cli.learn.runs.eval_dir_name` gives one file),
and runs them through :func:`tactile_cli.batch.run_each` (a local cluster of ``workers``
processes, an existing one at ``scheduler``, or this process with ``workers=0``). Each task
loads the run in its worker and calls :func:`~tactile_cli.learn.evaluate.evaluate` with
one file; the results folder is written atomically, so a stopped batch started again
skips every evaluation newer than its data file and the run's model, and redoes the rest
(``overwrite``: all of them). A failed file never stops the others.

Latency is not measured in these tasks: several evaluations running side by side on one
machine would time each other. Evaluate one file without ``each`` for the model's cost.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from ..batch import FileBatchResult, FileCounts, FileItem, newest_mtime, run_each
from ..config_file import missing_file_error
from ..errors import InputError
from ..input_guard import check_outputs
from ..store.atomic import remove_stale_temporaries
from ..store.outdir import check_output_folder
from ..store.provenance import current_command
from ..threads import check_threads
from . import runs

#: Why the batch has no latency figures (in each item's notes and the command's output).
NO_LATENCY = ("latency not measured: evaluations running side by side would time each "
              "other; evaluate one file on its own for the model's cost")


def _summary(result: Any) -> dict[str, Any]:
    """Per head: accuracy and macro F1 (classification) or MAE and RMSE (regression)."""
    from .evaluate import ClassificationMetrics

    heads: dict[str, Any] = {}
    for m in result.heads:
        if isinstance(m, ClassificationMetrics):
            heads[m.head] = {"accuracy": m.accuracy, "macro_f1": m.macro_f1}
        else:
            heads[m.head] = {"mae": m.mae, "rmse": m.rmse}
    return {"n_trials": result.n_trials, "n_windows": result.n_windows, "heads": heads}


def describe_item(item: FileItem) -> str:
    """What a finished file's line says after ``INPUT: ok``: its results folder and each
    head's accuracy or MAE."""
    from .tables import pct

    parts = []
    for head, m in item.value["summary"]["heads"].items():
        if "mae" in m:
            parts.append(f"{head} MAE " + ("n/a" if m["mae"] is None else f"{m['mae']:.4g}"))
        else:
            parts.append(f"{head} {pct(m['accuracy'])}")
    return f"-> {item.output} ({', '.join(parts)})"


def evaluate_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`evaluate_each` (module level, so Dask workers import it): spec
    ``{"run", "input", "split", "name", "overwrite", "command"}``. Returns ``{"out_dir",
    "summary", "notes"}``."""
    import torch

    from .evaluate import evaluate

    previous = torch.get_num_threads()
    torch.set_num_threads(1)  # one thread per task: the workers share the cores
    try:  # (restored: with workers=0 the task runs in the caller's process)
        result = evaluate(spec["run"], [spec["input"]], split=spec["split"],
                          name=spec["name"], latency=False, overwrite=spec["overwrite"],
                          command=spec["command"])
    finally:
        torch.set_num_threads(previous)
    return {"out_dir": str(result.out_dir), "summary": runs.json_safe(_summary(result)),
            "notes": [*result.notes, *result.warnings]}


def evaluate_each(
    run_dir: str | Path,
    data_paths: Sequence[str | Path],
    *,
    split: Literal["all", "test"] = "all",
    overwrite: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    command: str | None = None,
    on_plan: Callable[[list[FileItem]], None] | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FileBatchResult:
    """Evaluate the run on each data file apart (see the module docstring); never raises
    for a failed file: its item says ``failed`` with the one-line error. Refused before
    any work: a run folder that does not load, a missing data file, two files of one
    stem (one results folder)."""
    run_dir = Path(run_dir)
    if workers:  # 0: in this process
        check_threads(workers, "workers")
    info = runs.read_run_info(run_dir)  # a damaged run fails here, once, not per file
    if info.get("cv") is None:
        runs.load_run(run_dir)
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    paths = [Path(p) for p in data_paths]
    if not paths:
        raise InputError("no data files; give `data_paths`")
    seen: dict[str, Path] = {}
    for path in paths:
        if not path.exists():
            raise missing_file_error(path)
        name = runs.eval_dir_name([path], split)
        if name in seen:
            raise InputError(f"{str(seen[name])!r} and {str(path)!r} would both be written "
                             f"to {runs.EVAL_DIR}/{name}; rename one", path=path)
        seen[name] = path
    eval_dir = run_dir / runs.EVAL_DIR
    check_outputs([eval_dir / name for name in seen], paths)
    check_output_folder(eval_dir, merge=True)  # a file there, or a folder not writable
    model_mtime = max(newest_mtime(p) for p in (run_dir / runs.MODEL_PT,
                                               run_dir / runs.MODEL_ONNX,
                                               run_dir / runs.RUN_JSON) if p.exists())
    items = []
    for path in paths:
        out = run_dir / runs.EVAL_DIR / runs.eval_dir_name([path], split)
        done = (not overwrite and (out / runs.METRICS_JSON).is_file()
                and (out / runs.METRICS_JSON).stat().st_mtime > max(newest_mtime(path),
                                                                     model_mtime))
        items.append(FileItem(str(path), str(out), "skipped" if done else "todo"))
    if on_plan is not None:
        on_plan(items)
    command = command if command is not None else current_command()
    try:
        return run_each(evaluate_task, items,
                        lambda item: {"run": str(run_dir), "input": item.input,
                                      "split": split, "name": Path(item.output).name,
                                      # an out-of-date evaluation is replaced, as ingest does
                                      "overwrite": True, "command": command},
                        verb="evaluate", out_dir=str(eval_dir), scheduler=scheduler,
                        workers=workers, on_progress=on_progress, on_item=on_item)
    except BaseException:  # stopped: the temporary folders of the killed workers' tasks
        for item in items:
            remove_stale_temporaries(Path(item.output))
        raise


__all__ = ["NO_LATENCY", "describe_item", "evaluate_each", "evaluate_task"]
