"""`tactile train CONFIG --data FILE... [--out RUN]`"""

from __future__ import annotations

import datetime as _dt
import math
import sys
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE",
}


def data_files(data: list[Path] | None, ctx: typer.Context) -> list[Path]:
    """``--data`` values plus the files a shell glob put after it (``--data runs/*.h5``)."""
    extra = [Path(a) for a in ctx.args]
    for a in ctx.args:
        if a.startswith("-"):
            raise InputError(f"unknown option {a!r}; see --help")
    return [*(data or []), *extra]


def train_command(
    ctx: typer.Context,
    config: Annotated[Path, typer.Argument(help="Training config (YAML, see configs/train_*.yaml).",
                                           show_default=False)],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Tactile HDF5 file(s) to train on; repeat the option "
                     "or list several files after it.", show_default=False),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Run folder to write (default runs/<config>-<time>).",
                     show_default=False),
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Override the config's seed.")] = None,
    epochs: Annotated[
        int | None, typer.Option(min=1, help="Override optim.epochs.", show_default=False)
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing run folder.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    progress: Annotated[
        bool | None,
        typer.Option("--progress/--no-progress",
                     help="Show a progress bar (default: when stderr is a terminal; otherwise "
                     "one line per epoch on stderr).", show_default=False),
    ] = None,
) -> None:
    """Train a model of the registry (lstm, cnn1d, cnn2d_spectrogram, fnn, mlp) on windows of
    tactile HDF5 files and write a run folder: weights, resolved config, normalisation,
    history and curves, versions and data provenance. Deterministic with a seed on CPU."""

    def body() -> None:
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from ..learn.config import load_config
        from ..learn.runs import dumps
        from ..learn.train import EpochRecord, Prepared, train

        cfg = load_config(config).with_overrides(seed=seed, epochs=epochs)
        files = data_files(data, ctx)
        if not files:
            raise InputError("no data files; give --data FILE...")
        run_dir = out
        if run_dir is None:
            stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
            run_dir = Path("runs") / f"{config.stem}-{stamp}"
        console = Console(stderr=True)
        show_bar = console.is_terminal if progress is None else progress
        bar = Progress(TextColumn("{task.description}"), BarColumn(),
                       TextColumn("{task.completed}/{task.total} epochs"), TimeElapsedColumn(),
                       console=console, disable=not show_bar)
        task = bar.add_task("reading data", total=cfg.optim.epochs)

        def on_start(prep: Prepared) -> None:
            w = prep.windows
            line = (f"{cfg.model.family}: {len(prep.trials)} trials ({prep.assignment.mode} "
                    f"split {prep.assignment.counts()}), windows train {len(w['train']):,} "
                    f"val {len(w['val']):,} test {len(w['test']):,}")
            if show_bar:
                bar.console.print(line)
                bar.update(task, description="training")
            elif not as_json:
                print(line, file=sys.stderr)

        def on_epoch(r: EpochRecord) -> None:
            acc = "" if math.isnan(r.val_accuracy) else f" val acc {100 * r.val_accuracy:.2f} %"
            val = "" if math.isnan(r.val_loss) else f" val loss {r.val_loss:.4f}"
            text = f"epoch {r.epoch} loss {r.train_loss:.4f}{val}{acc}{' *' if r.best else ''}"
            if show_bar:
                bar.update(task, completed=r.epoch, description=text)
            elif not as_json:
                print(text, file=sys.stderr, flush=True)

        with bar:
            result = train(cfg, files, run_dir, config_path=config, overwrite=overwrite,
                           on_epoch=on_epoch, on_start=on_start)
        if as_json:
            typer.echo(dumps(result.as_dict()))
            return
        acc = result.best_val_accuracy
        typer.echo(
            f"wrote {result.run_dir}: {result.family}, {result.n_params:,} parameters, best "
            f"epoch {result.best_epoch}/{len(result.history)}"
            + ("" if math.isnan(acc) else f", val accuracy {100 * acc:.2f} %")
            + f", trained in {result.train_time_s:.1f} s on {result.threads} thread(s)")

    run_guarded(body, flags=FLAGS)
