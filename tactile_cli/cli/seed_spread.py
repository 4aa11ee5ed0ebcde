"""`tactile seed-spread CONFIG --data FILE... --cv K --seeds 0-4 --out FOLDER`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption
from ._errors import Flag, run_guarded
from ._options import DeviceOption, data_files
from ._output import Progress, echo_json, warn

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE...", "k": "--cv", "seeds": "--seeds", "out": "--out",
    "cv": "--cv", "eval_data": "--eval-data FILE", "epochs": "--epochs",
    "split_from": "--split-from", "overwrite": "--overwrite", "device": "--device",
    **BATCH_FLAGS,
}


def seed_spread_command(
    ctx: typer.Context,
    config: Annotated[Path, typer.Argument(help="Training config (YAML, see configs/train_*.yaml).",
                                           show_default=False, metavar="CONFIG")],
    out: Annotated[Path, typer.Option(
        "--out", "-o", help="Folder for seed_S/ run folders, seed_spread.json/.md/.png; built "
        "beside it and put in place when every seed is done (a stopped spread given the same "
        "folder resumes).", show_default=False,
        metavar="FOLDER")],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d", help="Tactile HDF5 file(s) to train on; repeat the option or list "
        "several files after it.", show_default=False, metavar="FILE")] = None,
    seeds: Annotated[str, typer.Option(
        metavar="SEEDS", help="Seeds to train at: 0,1,2, 0-4 or a mix.")] = "0-4",
    cv: Annotated[str | None, typer.Option(
        "--cv", metavar="K|loto", help="Folds per seed (as data.split says: grouped, blocked, "
        "stratified or random) or loto; default 5 unless --eval-data is given.",
        show_default=False)] = None,
    eval_data: Annotated[list[Path] | None, typer.Option(
        "--eval-data", help="Without --cv: train one model per seed on --data and score it on "
        "these files (trials it never saw). Repeat the option for several.",
        show_default=False, metavar="FILE")] = None,
    epochs: Annotated[int | None, typer.Option(
        min=1, help="Override optim.epochs.", show_default=False)] = None,
    split_from: Annotated[Path | None, typer.Option(
        "--split-from", metavar="CSV", help="Take every trial's split from a CSV (as `tactile "
        "train --split-from`): the same folds for every seed.", show_default=False)] = None,
    plot: Annotated[bool, typer.Option(
        "--plot/--no-plot", help="Write seed_spread.png.")] = True,
    overwrite: Annotated[bool, typer.Option(
        help="Replace an existing --out folder (once the new spread is done), and discard a "
        "stopped spread of another config beside it.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print seed_spread.json.")] = False,
    device: DeviceOption = "auto",
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    progress: Annotated[bool | None, typer.Option(
        "--progress/--no-progress", help="Show a progress bar (default: when stderr is a "
        "terminal; otherwise one line per seed on stderr).", show_default=False)] = None,
) -> None:
    """Train and evaluate one config at several seeds and report each seed's held-out
    figures beside their mean, SD, min, max and spread: how much of a figure is the seed
    (initial weights, batch order, a forest's bootstraps). A difference between two models
    smaller than this spread does not rank them. The seeds run side by side on Dask
    (--workers, --scheduler); each gives the same figures wherever it runs."""

    def body() -> None:
        from ..learn.seed_spread import parse_seeds, seed_line, seed_spread, spread_summary

        k = cv if cv is not None or eval_data else 5
        seed_list = parse_seeds(seeds)
        bar = Progress("seeds", "seeds", total=len(seed_list), show=progress, quiet=as_json)
        with bar.running():
            result = seed_spread(
                config, data_files(data, ctx), out=out, seeds=seed_list, cv=k,
                eval_data=eval_data, epochs=epochs, split_from=split_from,
                overwrite=overwrite, device=device, plot=plot, scheduler=scheduler,
                workers=workers, on_seed=lambda r: bar.step(seed_line(r), advance=1))
        warn(result.notes)
        if as_json:
            echo_json(result.as_dict())
        else:
            typer.echo(spread_summary(result))

    run_guarded(body, flags=FLAGS)

