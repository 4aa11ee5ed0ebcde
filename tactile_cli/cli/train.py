"""`tactile train CONFIG --data FILE... [--out RUN]`"""

from __future__ import annotations

import datetime as _dt
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded

if TYPE_CHECKING:
    from ..learn.config import TrainConfig
    from ..learn.splits import FoldPlan

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE",
    "k": "--cv",
    "jobs": "--jobs",
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
                                           show_default=False, metavar="CONFIG")],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Tactile HDF5 file(s) to train on; repeat the option "
                     "or list several files after it.", show_default=False, metavar="FILE"),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Run folder to write (default runs/<config>-<time>).",
                     show_default=False, metavar="RUN"),
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Override the config's seed.")] = None,
    epochs: Annotated[
        int | None, typer.Option(min=1, help="Override optim.epochs.", show_default=False)
    ] = None,
    cv: Annotated[
        str | None,
        typer.Option("--cv", metavar="K|loto",
                     help="Cross-validate: K folds (random, stratified or grouped as "
                     "data.split says) or loto (leave one trial out); one model per fold in "
                     "RUN/folds/. A stopped run resumes, skipping finished folds.",
                     show_default=False),
    ] = None,
    jobs: Annotated[
        int | None,
        typer.Option(min=1, help="--cv: folds trained at once, in separate processes "
                     "(default: the cores / optim.threads).", show_default=False),
    ] = None,
    split_from: Annotated[
        Path | None,
        typer.Option("--split-from", metavar="CSV",
                     help="Take every trial's split from a CSV (columns trial, split and, "
                     "where trial names repeat across files, file) instead of data.split.",
                     show_default=False),
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
    """Train a model of the registry (lstm, cnn1d, cnn2d_spectrogram, fnn, mlp, cnn2d_layout;
    or a classic one: logistic, random_forest, hist_gb, svm, stored as ONNX) on windows of
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

        if cv is not None:
            if split_from is not None:
                raise InputError("--split-from and --cv exclude each other: cross-validation "
                                 "makes its own folds")
            _train_cv(cfg, files, run_dir, cv, jobs, config, overwrite, as_json)
            return
        given = None
        if split_from is not None:
            from ..learn.splits import read_split_csv
            from ..learn.train import GivenSplits

            given = GivenSplits(read_split_csv(split_from), str(split_from), "csv")
        with bar:
            result = train(cfg, files, run_dir, config_path=config, overwrite=overwrite,
                           on_epoch=on_epoch, on_start=on_start, given=given)
        for w in result.warnings:
            print(f"tactile: warning: {w}", file=sys.stderr)
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


def _train_cv(cfg: TrainConfig, files: list[Path], run_dir: Path, cv: str, jobs: int | None,
              config: Path, overwrite: bool, as_json: bool) -> None:
    """``--cv``: train the folds with one line per fold on stderr."""
    from ..learn.cv import parse_cv, train_cv
    from ..learn.runs import dumps

    k = parse_cv(cv)

    def on_plan(plan: FoldPlan, finished: list[int]) -> None:
        if as_json:
            return
        from ..learn.splits import fold_text

        again = f", {len(finished)} already finished (resuming)" if finished else ""
        print(f"{cfg.model.family}: "
              f"{fold_text(plan.k, len(plan.folds), plan.mode, plan.by)}{again}",
              file=sys.stderr, flush=True)
        for w in plan.warnings:
            print(f"tactile: warning: {w}", file=sys.stderr)

    def on_fold(index: int, summary: dict[str, Any]) -> None:
        if not as_json:
            acc = summary.get("best_val_accuracy")
            val = "" if acc is None or math.isnan(acc) else f", val accuracy {100 * acc:.2f} %"
            n = summary["n_trials"]
            print(f"fold {index}: {n['train']} training, {n['val']} validation, {n['test']} "
                  f"held-out trials, best epoch "
                  f"{summary['best_epoch']}/{summary['epochs_run']}{val}, "
                  f"{summary['train_time_s']:.1f} s", file=sys.stderr, flush=True)

    result = train_cv(cfg, files, run_dir, k=k, jobs=jobs, config_path=config,
                      overwrite=overwrite, on_plan=on_plan, on_fold=on_fold)
    if as_json:
        typer.echo(dumps(result.as_dict()))
        return
    typer.echo(f"wrote {result.run_dir}: {result.family}, {result.n_folds} folds "
               f"({result.mode}), {len(result.trained)} trained in {result.wall_time_s:.1f} s "
               f"with {result.jobs} process(es); evaluate with `tactile evaluate "
               f"{result.run_dir}`")
