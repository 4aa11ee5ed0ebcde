"""`tactile sweep SWEEP.yaml --out DIR [--data FILE...] [--eval-data FILE...]
[--scheduler ADDRESS] [--workers N] [--overwrite] [--json] [--no-progress]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._batch import BATCH_FLAGS, scheduler_option, workers_option
from ._errors import EXIT_BAD_INPUT, Flag, run_guarded
from ._options import DeviceOption
from ._output import Progress, echo_json

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"train_data": "--data", **BATCH_FLAGS}
SweepScheduler = scheduler_option("")
SweepWorkers = workers_option("", unit="run")


def sweep_command(
    config: Annotated[Path, typer.Argument(help="Sweep file (YAML, see configs/sweep_vibro.yaml).",
                                           show_default=False, metavar="CONFIG")],
    out: Annotated[Path, typer.Option(
        "--out", "-o", help="Folder for sweep.json, table.csv/.md, sweep_results.json, the "
        "figures and runs/ (a stopped sweep given the same folder skips its finished runs).",
        metavar="FOLDER", show_default=False)],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d", help="Training file(s); replace the sweep file's train_data. Repeat the "
        "option for several.", show_default=False, metavar="FILE")] = None,
    eval_data: Annotated[list[Path] | None, typer.Option(
        "--eval-data", help="Evaluation file(s); replace the sweep file's eval.data. Repeat the "
        "option for several.", show_default=False, metavar="FILE")] = None,
    scheduler: SweepScheduler = None,
    workers: SweepWorkers = None,
    overwrite: Annotated[bool, typer.Option(help="Run every run again, and write into a "
                                            "folder that holds no sweep.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print sweep_results as JSON.")
                       ] = False,
    device: DeviceOption = "auto",
    progress: Annotated[bool | None, typer.Option(
        "--progress/--no-progress", help="Show a progress bar (default: when stderr is a "
        "terminal; otherwise one line per finished run on stderr).", show_default=False)] = None,
) -> None:
    """Train and evaluate every model x window x channel set of a sweep file on Dask, then
    write one table (CSV, markdown, JSON), accuracy against window size (paper 001, Fig. 8)
    and accuracy against latency with the Pareto front. A failed run is a table row with its
    error; a stopped sweep restarted with the same --out skips its finished runs."""

    def body() -> None:
        from ..learn.sweep import run_sweep

        bar = Progress("sweep", "runs", show=progress, quiet=as_json)
        with bar.running():
            result = run_sweep(config, out, train_data=data, eval_data=eval_data,
                               scheduler=scheduler, workers=workers, overwrite=overwrite,
                               device=device,
                               on_line=bar.say, on_progress=lambda c: bar.update(
                                   total=c.total, completed=c.done + c.failed,
                                   description=f"sweep: {c.text()}"))
        if as_json:
            echo_json(result.as_dict())
        else:
            typer.echo(result.text(), nl=False)
        if result.n_failed:  # after the table: the runs that worked are written
            raise typer.Exit(code=EXIT_BAD_INPUT)

    run_guarded(body, flags=FLAGS)
