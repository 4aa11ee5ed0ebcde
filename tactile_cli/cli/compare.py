"""`tactile compare RUN... [--data-name NAME] [--margin 0.5] [--metric accuracy] [--out FOLDER]
[--json]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._output import echo_json, print_blocks, warn

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_name": "--data-name", "metric": "--metric", "margin_pp": "--margin", "out_dir": "--out",
    "targets": "--target",
}


def compare_command(
    runs: Annotated[list[Path], typer.Argument(
        help="Run folders written by `tactile train`, each evaluated with `tactile evaluate` on "
        "the same data, or folders of `tactile seed-spread` (each one point: the mean over its "
        "seeds, with their SD).", metavar="RUN", show_default=False)],
    data_name: Annotated[str | None, typer.Option(
        "--data-name",
        help="Evaluation to compare (RUN/eval/<name>); default: the one every run has.",
        metavar="NAME", show_default=False)] = None,
    margin: Annotated[float, typer.Option(
        min=0.0, help="Accuracy margin in percentage points: the model this scene needs is the "
        "smallest within it of the best.")] = 0.5,
    metric: Annotated[str, typer.Option(
        help="Score to compare: accuracy (per window), macro_f1, trial_accuracy (majority vote "
        "per trial, for trial-level targets), group_accuracy (majority vote per group of "
        "trials decided together, a config's data.decide_by) or f1:<class> (e.g. f1:slip) of "
        "the primary head."
    )] = "accuracy",
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Folder for compare.png (accuracy against latency, Pareto front), "
        "compare.csv and compare.json.", metavar="FOLDER", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print compare.json to stdout.")
                       ] = False,
    target: Annotated[list[str] | None, typer.Option(
        "--target", help="HEAD=VALUE, repeatable: an accuracy (fraction) a classification head "
        "must reach or an MAE a regression head must not exceed; the model this scene needs is "
        "then the smallest meeting every target (e.g. --target motion=0.948 --target "
        "speed_cm_s=3.4).", metavar="HEAD=VALUE", show_default=False)] = None,
) -> None:
    """Compare runs on one evaluation: accuracy against latency per window (batch 1), the
    Pareto front, and the model this scene needs (the fewest parameters within --margin
    of the best accuracy, or meeting every --target, ties by latency) beside the fastest
    such run."""

    def body() -> None:
        from ..learn.compare import compare_runs, comparison_record
        from ..learn.tables import comparison_table

        cmp = compare_runs(runs, data_name=data_name, margin_pp=margin, metric=metric,
                           targets=target or [], out_dir=out)
        warn(cmp.notes)
        if as_json:
            echo_json(comparison_record(cmp))
            return
        # on a terminal the run names fold over lines where it is narrow; into a file or a
        # pipe the table is as wide as it needs, so no name is cut or folded
        print_blocks([comparison_table(cmp)], width="natural")
        typer.echo(cmp.summary())
        if cmp.files is not None:
            typer.echo(f"wrote {cmp.files.png}, {cmp.files.csv.name}, {cmp.files.json.name}")

    run_guarded(body, flags=FLAGS)
