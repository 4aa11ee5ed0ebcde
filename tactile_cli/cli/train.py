"""`tactile train CONFIG --data FILE... [--out RUN]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import DeviceOption, data_files
from ._output import Progress, echo_json, warn

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"data_paths": "--data FILE...", "k": "--cv"}


def train_command(
    ctx: typer.Context,
    config: Annotated[Path, typer.Argument(help="Training config (YAML, see configs/train_*.yaml).",
                                           show_default=False, metavar="CONFIG")],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d",
        help="Tactile HDF5 file(s) to train on; repeat the option or list several files after it.",
        show_default=False, metavar="FILE")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Run folder to write (default runs/<config>-<time>).",
        show_default=False, metavar="RUN")] = None,
    seed: Annotated[int | None, typer.Option(help="Override the config's seed.")] = None,
    epochs: Annotated[int | None, typer.Option(
        min=1, help="Override optim.epochs.", show_default=False)] = None,
    cv: Annotated[str | None, typer.Option(
        "--cv", metavar="K|loto", help="Cross-validate: K folds (random, stratified or grouped "
        "as data.split says) or loto (leave one trial out); one model per fold in RUN/folds/. A "
        "stopped run resumes, skipping finished folds.", show_default=False)] = None,
    jobs: Annotated[int | None, typer.Option(
        min=1, help="--cv: folds trained at once, in separate processes (default: the cores / "
        "optim.threads).", show_default=False)] = None,
    split_from: Annotated[Path | None, typer.Option(
        "--split-from", metavar="CSV", help="Take every trial's split from a CSV (columns trial, "
        "split and, where trial names repeat across files, file) instead of data.split.",
        show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing run folder.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    device: DeviceOption = "auto",
    progress: Annotated[bool | None, typer.Option(
        "--progress/--no-progress", help="Show a progress bar (default: when stderr is a "
        "terminal; otherwise one line per epoch on stderr).", show_default=False)] = None,
) -> None:
    """Train a model of the registry (lstm, cnn1d, cnn2d_spectrogram, fnn, mlp, cnn2d_layout,
    cnn2d_frames on image sequences;
    or a classic one: logistic, random_forest, hist_gb, svm, stored as ONNX) on windows of
    tactile HDF5 files and write a run folder: weights, resolved config, normalisation,
    history and curves, versions and data provenance. Deterministic with a seed on CPU."""

    def body() -> None:
        from ..learn.pipeline import epoch_line, train_run, train_summary

        bar = Progress("reading data", "epochs", show=False if cv else progress, quiet=as_json)
        with bar.running():
            result = train_run(
                config, data_files(data, ctx), out=out, seed=seed, epochs=epochs, cv=cv,
                jobs=jobs, split_from=split_from, overwrite=overwrite,
                on_start=lambda _, cfg: bar.update(description="training",
                                                   total=cfg.optim.epochs),
                on_epoch=lambda r: bar.step(epoch_line(r), completed=r.epoch),
                on_line=bar.say, device=device)
        warn(result.warnings)
        if as_json:
            echo_json(result.as_dict())
        else:
            typer.echo(train_summary(result))

    run_guarded(body, flags=FLAGS)
