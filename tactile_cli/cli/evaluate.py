"""`tactile evaluate RUN --data FILE... [--split test|all] [--json]`"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from .train import data_files

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE",
    "split": "--split",
    "threshold": "--threshold",
}


def evaluate_command(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(help="Run folder written by `tactile train`.",
                                        show_default=False)],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Tactile HDF5 file(s) to evaluate on; repeat the "
                     "option or list several files after it.", show_default=False),
    ] = None,
    split: Annotated[
        str, typer.Option(help="all: every trial; test: the trials the run's split rule puts "
                          "in test (on the training files, the training's test split).")
    ] = "all",
    name: Annotated[
        str | None,
        typer.Option(help="Name of the results folder RUN/eval/<name> (default from the data "
                     "file names).", show_default=False),
    ] = None,
    threads: Annotated[
        int, typer.Option(min=1, help="torch CPU threads for the latency measurement.")
    ] = 1,
    latency: Annotated[
        bool, typer.Option("--latency/--no-latency", help="Measure latency and throughput.")
    ] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print metrics.json to stdout.")] = False,
    perturb: Annotated[
        bool, typer.Option("--perturb", help="Also re-evaluate on perturbed copies of the data "
                           "(see `tactile perturb`); results in RUN/perturb/<name>/.")
    ] = False,
    perturb_kinds: Annotated[
        str, typer.Option("--perturb-kinds", help="Kinds for --perturb: noise, lowpass, drop, "
                          "drop_events, drop_samples, scale (comma-separated).")
    ] = "noise,lowpass,drop,scale",
    threshold: Annotated[
        str, typer.Option(help="--perturb breaking point: accuracy below a factor of the clean "
                          "accuracy (0.9x) or an accuracy (0.95 or 95%).")
    ] = "0.9x",
) -> None:
    """Evaluate a trained run: overall accuracy, per-class precision/recall/F1 and confusion
    matrix (PNG + JSON) per classification head, MAE/RMSE per regression head, latency per
    window at batch 1 and windows/s at batch 1024 on this machine, parameters and size.
    Files go to RUN/eval/<name>/."""

    def body() -> None:
        from rich.console import Console
        from rich.table import Table

        from ..learn.evaluate import ClassificationMetrics, evaluate
        from ..learn.runs import dumps

        files = data_files(data, ctx)
        if not files:
            raise InputError("no data files; give --data FILE...")
        if split not in ("all", "test"):
            raise InputError(f"--split must be all or test, got {split!r}")
        if perturb:
            from .perturb import parse_threshold

            parse_threshold(threshold)  # a bad value fails before any work
        result = evaluate(run, files, split=split, name=name,  # type: ignore[arg-type]
                          latency=latency, threads=threads)
        if as_json:
            payload = result.as_dict()
            if perturb:
                from .perturb import perturb_and_print

                perturbed = perturb_and_print([run], files, kinds=perturb_kinds,
                                              threshold=threshold, split=split, name=name,
                                              echo=False, notes=False)
                payload = {"evaluation": payload, "perturbation": perturbed[0].as_dict()}
            typer.echo(dumps(payload))
        else:
            console = Console(width=None if sys.stdout.isatty() else 120)
            console.print(f"[bold]{result.run}[/] ({result.family}) on {result.n_trials} "
                          f"trials, {result.n_windows:,} windows, split {result.split}")
            for m in result.heads:
                if isinstance(m, ClassificationMetrics):
                    table = Table(title=f"{m.head}: accuracy {100 * m.accuracy:.2f} %")
                    for col in ("class", "precision", "recall", "F1", "support"):
                        table.add_column(col, justify="left" if col == "class" else "right")
                    for c in m.per_class:
                        table.add_row(c.name, f"{c.precision:.5f}", f"{c.recall:.5f}",
                                      f"{c.f1:.5f}", f"{c.support:,}")
                    if m.accuracy_excluding_boundaries is not None:
                        table.caption = (
                            f"without the {m.n_near_boundary:,} windows within "
                            f"{m.boundary_margin} sample(s) of a label change: "
                            f"{100 * m.accuracy_excluding_boundaries:.2f} %")
                    console.print(table)
                else:
                    console.print(f"{m.head}: MAE {m.mae:.4g}, RMSE {m.rmse:.4g} ({m.n:,} "
                                  "windows)")
            cost = Table(title="Cost on this machine")
            for col in ("parameters", "size (MB)", "batch-1 median (ms)", "batch-1 p95 (ms)",
                        "windows/s", "threads"):
                cost.add_column(col, justify="right")
            lat = result.latency
            cost.add_row(f"{result.n_params:,}", f"{result.size_mb:.3f}",
                         "" if lat is None else f"{lat.batch1_ms_median:.3f}",
                         "" if lat is None else f"{lat.batch1_ms_p95:.3f}",
                         "" if lat is None else f"{lat.windows_per_s:,.0f}",
                         "" if lat is None else str(lat.threads))
            console.print(cost)
            console.print(f"wrote {result.out_dir}")
            if perturb:
                from .perturb import perturb_and_print

                perturb_and_print([run], files, kinds=perturb_kinds, threshold=threshold,
                                  split=split, name=name, notes=False)
        for note in result.notes:
            print(f"tactile: warning: {note}", file=sys.stderr)
        if result.overlaps_training and split == "all":
            print(f"tactile: warning: {', '.join(result.overlaps_training)} was used to train "
                  "this run; these metrics include training trials (use --split test)",
                  file=sys.stderr)

    run_guarded(body, flags=FLAGS)
