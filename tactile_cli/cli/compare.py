"""`tactile compare RUN... [--data-name NAME] [--margin 0.5] [--metric accuracy] [--out FOLDER]
[--json]`"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ._errors import Flag, run_guarded

if TYPE_CHECKING:
    from rich.table import Table

    from ..learn.compare import Comparison

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_name": "--data-name",
    "metric": "--metric",
    "margin_pp": "--margin",
    "out_dir": "--out",
    "targets": "--target",
}


def runs_and_files(paths: list[Path] | None, data: list[Path] | None) -> tuple[list[Path],
                                                                              list[Path]]:
    """Split positional paths into run folders and data files: a run is a folder, so a
    positional path that is a file is a data file (``--data a.h5 b.h5`` leaves ``b.h5``
    among the positional arguments)."""
    runs, files = [], list(data or [])
    for p in paths or []:
        (files if p.is_file() else runs).append(p)
    return runs, files


def compare_command(
    runs: Annotated[
        list[Path], typer.Argument(help="Run folders written by `tactile train`, each evaluated "
                                   "with `tactile evaluate` on the same data.",
                                   metavar="RUN", show_default=False)],
    data_name: Annotated[
        str | None,
        typer.Option("--data-name", help="Evaluation to compare (RUN/eval/<name>); default: "
                     "the one every run has.", metavar="NAME", show_default=False),
    ] = None,
    margin: Annotated[
        float, typer.Option(min=0.0, help="Accuracy margin in percentage points: the model "
                            "this scene needs is the smallest within it of the best.")
    ] = 0.5,
    metric: Annotated[
        str, typer.Option(help="Score to compare: accuracy (per window), macro_f1, "
                          "trial_accuracy (majority vote per trial, for trial-level targets) "
                          "or f1:<class> (e.g. f1:slip) of the primary head.")
    ] = "accuracy",
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Folder for compare.png (accuracy against latency, "
                     "Pareto front), compare.csv and compare.json.", metavar="FOLDER",
                     show_default=False),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print compare.json to stdout.")
                       ] = False,
    target: Annotated[
        list[str] | None,
        typer.Option("--target", help="HEAD=VALUE, repeatable: an accuracy (fraction) a "
                     "classification head must reach or an MAE a regression head must not "
                     "exceed; the model this scene needs is then the smallest meeting every "
                     "target (e.g. --target motion=0.948 --target speed_cm_s=3.4).",
                     metavar="HEAD=VALUE", show_default=False),
    ] = None,
) -> None:
    """Compare runs on one evaluation: accuracy against latency per window (batch 1), the
    Pareto front, and the model this scene needs (the fewest parameters within --margin
    of the best accuracy, or meeting every --target, ties by latency) beside the fastest
    such run."""

    def body() -> None:
        from rich.console import Console

        from ..learn.compare import compare, comparison_record, write_comparison
        from ..learn.runs import dumps

        cmp = compare(runs, data_name=data_name, margin_pp=margin, metric=metric,
                      targets=_parse_targets(target or []))
        files = write_comparison(cmp, out) if out is not None else None
        for note in cmp.notes:
            print(f"tactile: warning: {note}", file=sys.stderr)
        if as_json:
            typer.echo(dumps(comparison_record(cmp)))
            return
        table = _table(cmp)
        # on a terminal the run names fold over lines where it is narrow; into a file or a
        # pipe the table is as wide as it needs, so no name is cut or folded
        console = Console(width=None if sys.stdout.isatty() else _natural_width(table))
        console.print(table)
        typer.echo(cmp.summary())
        if files is not None:
            typer.echo(f"wrote {files.png}, {files.csv.name}, {files.json.name}")

    run_guarded(body, flags=FLAGS)


def _parse_targets(items: list[str]) -> dict[str, float]:
    """``["motion=0.948", "speed_cm_s=3.4"]`` -> ``{"motion": 0.948, "speed_cm_s": 3.4}``."""
    from ..errors import InputError

    out: dict[str, float] = {}
    for item in items:
        head, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not head.strip() or number != number:
            raise InputError(f"--target {item!r}: give HEAD=VALUE, e.g. motion=0.948")
        if head.strip() in out:
            raise InputError(f"--target {head.strip()!r} given twice")
        out[head.strip()] = number
    return out


def _table(cmp: Comparison) -> Table:
    """The comparison table; each run named by the part of its folder that tells it apart
    from the others (:func:`~tactile_cli.learn.compare.distinct_run_paths`)."""
    from rich.table import Table

    from ..learn.compare import distinct_run_paths, table_rows

    rows = table_rows(cmp)
    exported = any(row["exported_latency_ms"] is not None for row in rows)
    table = Table(title=f"{cmp.metric_label} against cost on {cmp.data_name}")
    table.add_column("run", overflow="fold")
    table.add_column("family")
    for col in (f"{cmp.metric_label} (%)", "vs best (pp)", "batch-1 ms", "p95 ms",
                *(("exported ms",) if exported else ()),
                "windows/s", "parameters", "MB", "Pareto", "in margin", ""):
        table.add_column(col, justify="right")
    for row, name in zip(rows, distinct_run_paths([row["run"] for row in rows]), strict=True):
        lat = row["latency_ms_median"]
        table.add_row(
            name, row["family"], f"{row['score_pct']:.2f}", f"{row['delta_pp']:+.2f}",
            "" if lat is None else f"{lat:.3f}",
            "" if row["latency_ms_p95"] is None else f"{row['latency_ms_p95']:.3f}",
            *(("" if row["exported_latency_ms"] is None
               else f"{row['exported_latency_ms']:.3f}",) if exported else ()),
            "" if row["windows_per_s"] is None else f"{row['windows_per_s']:,.0f}",
            f"{row['n_params']:,}", f"{row['size_mb']:.4f}",
            "*" if row["pareto"] else "", "*" if row["within_margin"] else "",
            ("needed" if row["needed"] else ("fastest" if row["fastest"] else ""))
            + ("" if row["meets_targets"] is None else
               (" (meets targets)" if row["meets_targets"] else " (misses a target)")))
    return table


def _natural_width(table: Table) -> int:
    """Columns the table takes when nothing wraps."""
    from rich.console import Console

    return Console(width=10_000).measure(table).maximum
