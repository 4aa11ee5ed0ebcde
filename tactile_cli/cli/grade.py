"""`tactile grade FILE... [--config C] [--json] [--plot DIR] [--calibrate --out NEW.yaml]`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from ._errors import Flag, run_guarded

if TYPE_CHECKING:
    from ..grade.pipeline import GradeRun

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"label_key": "--label-key", "out": "--out", "plot": "--plot",
                          "calibrate": "--calibrate", "overlap": "--overlap",
                          "config": "--config"}


def _fmt(v: float | None, spec: str = ".4f") -> str:
    return "" if v is None or v != v else format(v, spec)


def grade_command(
    files: Annotated[list[Path], typer.Argument(
        help="Tactile HDF5 files (events or an event-count stream with a `net` channel) or "
             "CSV tables trial,area[,level].", metavar="FILE", show_default=False)],
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Grader YAML config (default: the marker-sensor config "
        "shipped with tactile, configs/grade_marker.yaml).", metavar="FILE",
        show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Write membership, inference and area-vs-level PNGs to this folder.",
        metavar="FOLDER", show_default=False)] = None,
    calibrate: Annotated[bool, typer.Option(
        "--calibrate", help="Fit the input membership functions to the labelled trials and "
        "write a new config to --out.")] = False,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output config of --calibrate.", metavar="FILE",
        show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing --out file.")] = False,
    label_key: Annotated[str | None, typer.Option(
        "--label-key", help="Trial label holding the truth: force_grade or force_level "
        "(default: force_grade when present, else force_level).", show_default=False)] = None,
    overlap: Annotated[float, typer.Option(
        min=0.01, max=1.0, help="--calibrate: transition width of neighbouring terms as a "
        "fraction of the room around each boundary.")] = 0.5,
) -> None:
    """Grade the pressing force of every trial with a Mamdani fuzzy classifier (paper 000,
    sec. 5.3, Table III) over the area of net pressing events in the press region.

    Prints per trial the crisp output, the grade, the firing strength of every rule and the
    true grade when the trial is labelled, then the fraction graded right, off by one grade
    and worse, and the Pearson r of the area with the force level (Fig. 15).
    """

    def body() -> None:
        from ..grade.pipeline import grade_files

        run = grade_files(files, config=config, label_key=label_key, plot=plot,
                          calibrate=calibrate, out=out, overlap=overlap, overwrite=overwrite)
        if as_json:
            typer.echo(json.dumps(run.as_dict(), indent=2))
        else:
            _print(run, multi_file=len({str(f) for f in files}) > 1)

    run_guarded(body, flags=FLAGS)


def _print(run: GradeRun, *, multi_file: bool) -> None:
    """The calibration, one row per trial and the accuracy and correlation lines."""
    console = Console(width=None if sys.stdout.isatty() else 160)
    report, cfg, calib = run.report, run.config, run.calibration
    if calib is not None:
        t = Table(title=f"Calibration (written to {calib.out})")
        for col in ("grade", "n", "Q25", "median", "Q75", "upper boundary"):
            t.add_column(col)
        for row in calib.per_grade:
            t.add_row(row["grade"], str(row["n"]), f"{row['q25']:.6g}", f"{row['median']:.6g}",
                      f"{row['q75']:.6g}", _fmt(row["upper_boundary"], ".6g"))
        console.print(t)
    table = Table(title=f"Force grades ({run.config_path}, {report.method} centroid)")
    cols = (["file"] if multi_file else []) + [
        "trial", cfg.input.name, "crisp", "grade", "true", "rules fired (strength)"]
    for col in cols:
        table.add_column(col)
    for t in report.trials:
        fired = ", ".join(f"{k}={v:.2f}" for k, v in t.firing.items() if v > 0)
        if t.status != "ok":
            fired = t.status
        true = t.true_grade or ""
        if t.true_level is not None:
            true += f" (level {t.true_level})"
        grade = t.grade or "-"
        if t.error not in (None, 0):
            grade = f"[red]{grade}[/]"
        row = ([Path(t.file).name] if multi_file else []) + [
            t.trial, _fmt(t.area, ".6g"), _fmt(t.crisp), grade, true, fired]
        table.add_row(*row)
    console.print(table)
    s = report.summary
    if s.n_labelled:
        console.print(
            f"{s.n_labelled} labelled trials: {100 * s.accuracy:.1f} % graded right, "
            f"{100 * s.off_by_one:.1f} % off by one grade, {100 * s.worse:.1f} % worse")
    if s.pearson_r is not None:
        console.print(f"Pearson r of {cfg.input.name} with {s.correlation_with.replace('_', ' ')}: "
                      f"{s.pearson_r:.4f} ({s.n_correlation} trials)")
    if s.n_graded < s.n_trials:
        console.print(f"{s.n_trials - s.n_graded} trial(s) not graded (see the rules column)")
    for p in run.plots:
        console.print(f"wrote {p}")
