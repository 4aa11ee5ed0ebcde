"""`tactile report RUN... --out DIR [--data FILE...] [--figures DIR...]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from ._options import data_files, runs_and_files

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "run_dirs": "RUN folders", "data_paths": "--data FILE", "figure_dirs": "--figures DIR",
    "out_dir": "--out", "metric": "--metric", "margin_pp": "--margin",
}


def report_command(
    ctx: typer.Context,
    runs: Annotated[list[Path] | None, typer.Argument(
        help="Run folders written by `tactile train`, or folders of `tactile seed-spread` (their "
        "seeds' table and plot, and each seed's run). A path that is a file is taken as a data "
        "file (so `--data *.h5` works).", metavar="RUN", show_default=False)] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Folder for index.html and report.json.", show_default=False,
        metavar="FOLDER")] = None,
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d", help="Tactile HDF5 file(s) to summarise.", show_default=False,
        metavar="FILE")] = None,
    figures: Annotated[list[Path] | None, typer.Option(
        "--figures", help="Folder whose PNG files (recursively) are added, grouped by what they "
        "show and captioned in words (many of one kind: one grid with the count); repeatable.",
        show_default=False, metavar="FOLDER")] = None,
    title: Annotated[str | None, typer.Option(help="Page title.", show_default=False)] = None,
    margin: Annotated[float, typer.Option(
        min=0.0, help="Accuracy margin (percentage points) of the comparison.")] = 0.5,
    metric: Annotated[str, typer.Option(
        help="Score of the comparison: auto (per-group accuracy where every run decides groups "
        "of trials together, a config's data.decide_by; else per-trial accuracy where every "
        "run votes per trial, e.g. texture; else accuracy per window), accuracy, macro_f1, "
        "trial_accuracy, group_accuracy or f1:<class>.")] = "auto",
) -> None:
    """Write one self-contained HTML page (figures embedded): where every number comes
    from (each result tagged recorded, simulated or synthetic, recorded data first), the
    comparison, the perturbation charts, every run's config, curves, metrics (with
    cross-validation folds, intervals and per-trial results when evaluated so), confusion
    matrices and cost, the data files' summaries and the extra figures. Prints the path of
    index.html."""

    def body() -> None:
        from ..learn.report import build_report

        if out is None:
            raise InputError("give the output folder with --out DIR")
        run_dirs, files = runs_and_files([*(runs or []), *data_files(None, ctx)], data)
        result = build_report(run_dirs, out, data_paths=files, figure_dirs=figures or [],
                              title=title, margin_pp=margin, metric=metric)
        typer.echo(str(result.index))

    run_guarded(body, flags=FLAGS)
