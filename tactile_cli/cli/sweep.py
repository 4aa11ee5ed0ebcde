"""`tactile sweep SWEEP.yaml --out DIR [--data FILE...] [--eval-data FILE...]
[--scheduler ADDRESS] [--workers N] [--overwrite] [--json] [--no-progress]`"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ._batch import BATCH_FLAGS, scheduler_option, workers_option
from ._errors import Flag, run_guarded

if TYPE_CHECKING:
    from ..learn.sweep import PlannedRun, SweepCounts, SweepResult

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "train_data": "--data",
    "eval_data": "--eval-data",
    **BATCH_FLAGS,
}
SweepScheduler = scheduler_option("")
SweepWorkers = workers_option("", unit="run")


def sweep_command(
    config: Annotated[Path, typer.Argument(help="Sweep file (YAML, see configs/sweep_vibro.yaml).",
                                           show_default=False, metavar="CONFIG")],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Folder for sweep.json, table.csv/.md, "
                           "sweep_results.json, the figures and runs/ (a stopped sweep "
                           "given the same folder skips its finished runs).",
                           metavar="FOLDER", show_default=False)],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Training file(s); replace the sweep file's "
                     "train_data. Repeat the option for several.", show_default=False,
                     metavar="FILE"),
    ] = None,
    eval_data: Annotated[
        list[Path] | None,
        typer.Option("--eval-data", help="Evaluation file(s); replace the sweep file's "
                     "eval.data. Repeat the option for several.", show_default=False,
                     metavar="FILE"),
    ] = None,
    scheduler: SweepScheduler = None,
    workers: SweepWorkers = None,
    overwrite: Annotated[bool, typer.Option(help="Run every run again, and write into a "
                                            "folder that holds no sweep.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print sweep_results as JSON.")
                       ] = False,
    progress: Annotated[
        bool | None,
        typer.Option("--progress/--no-progress",
                     help="Show a progress bar (default: when stderr is a terminal; otherwise "
                     "one line per finished run on stderr).", show_default=False),
    ] = None,
) -> None:
    """Train and evaluate every model x window x channel set of a sweep file on Dask, then
    write one table (CSV, markdown, JSON), accuracy against window size (paper 001, Fig. 8)
    and accuracy against latency with the Pareto front. A failed run is a table row with its
    error; a stopped sweep restarted with the same --out skips its finished runs."""

    def body() -> None:
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from ..learn.runs import dumps
        from ..learn.sweep import load_sweep, run_sweep

        cfg = load_sweep(config)
        console = Console(stderr=True)
        show_bar = console.is_terminal if progress is None else progress
        bar = Progress(TextColumn("{task.description}"), BarColumn(),
                       TextColumn("{task.completed}/{task.total} runs"), TimeElapsedColumn(),
                       console=console, disable=not show_bar)
        task = bar.add_task(f"sweep {cfg.name}", total=None)

        def say(line: str) -> None:
            if show_bar:
                bar.console.print(line)
            elif not as_json:
                print(line, file=sys.stderr, flush=True)

        def on_plan(planned: list[PlannedRun]) -> None:
            n = {s: sum(r.status == s for r in planned) for s in ("todo", "finished", "n/a")}
            say(f"sweep {cfg.name}: {len(planned)} runs in the grid: {n['todo']} to run, "
                f"{n['finished']} finished before (skipped), {n['n/a']} n/a")

        def on_progress(c: SweepCounts) -> None:
            text = (f"{c.done}/{c.total} done, {c.running} running, {c.failed} failed")
            bar.update(task, total=c.total, completed=c.done + c.failed,
                       description=f"sweep {cfg.name}: {text}")

        def on_run(name: str, ok: bool, error: str | None) -> None:
            say(f"{name}: ok" if ok else f"{name}: failed: {error}")

        with bar:
            result = run_sweep(cfg, out, config_path=config, train_data=data,
                               eval_data=eval_data, scheduler=scheduler, workers=workers,
                               overwrite=overwrite, on_plan=on_plan, on_progress=on_progress,
                               on_run=on_run)
        if as_json:
            typer.echo(dumps(result.as_dict()))
            return
        _print(result)

    run_guarded(body, flags=FLAGS)


def _print(result: SweepResult) -> None:
    """The table (markdown, as written to table.md) and the summary line."""
    from ..learn.sweep import table_markdown

    typer.echo(table_markdown(result.rows, result.heads), nl=False)
    typer.echo(result.summary())
    for note in result.notes:
        typer.echo(f"note: {note}")
    typer.echo(f"wrote {result.out_dir}: sweep.json, table.csv, table.md, "
               "sweep_results.json, accuracy_vs_window.png, speed_accuracy.png, runs/")
