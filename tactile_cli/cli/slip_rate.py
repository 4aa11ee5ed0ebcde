"""`tactile slip-rate FILE`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ._errors import Flag, run_guarded, to_flags

if TYPE_CHECKING:
    from ..spatial.pipeline import SlipRateReport

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``):
#: the library takes the ROIs and optics as ``config``, this command as the --rois file.
FLAGS: dict[str, Flag] = {"config": "--rois", "plot": "--plot"}


def _fmt(value: float | None, scale: float = 1.0, digits: int = 4) -> str:
    if value is None or value != value:  # None or NaN
        return "-"
    return f"{value * scale:.{digits}f}"


def _print(report: SlipRateReport, *, title: str) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console(width=None if sys.stdout.isatty() else 160)
    table = Table(title=title)
    for col in ("trial", "status", "speed (m/s)", "+- se", "displacement (m)", "+- se",
                "truth (m/s)", "error", "r2", "ROIs"):
        table.add_column(col)
    for r in report.results:
        err = r["speed_rel_error"]
        table.add_row(
            r["trial"], r["status"] if r["status"] == "ok" else
            f"{r['status']}: {to_flags(r['message'], FLAGS)}",
            _fmt(r["speed_m_s"], digits=6), _fmt(r["speed_se_m_s"], digits=6),
            _fmt(r["displacement_m"], digits=6), _fmt(r["displacement_se_m"], digits=6),
            _fmt(r["truth_speed_m_s"], digits=6),
            "-" if err is None else f"{err * 100:+.1f} %", _fmt(r["r2"], digits=3),
            str(r["n_rois_used"]),
        )
    console.print(table)
    s = report.summary
    if s["n_with_truth"]:
        console.print(f"speed error vs truth over {s['n_with_truth']} trial(s): mean "
                      f"|error| {s['mean_abs_rel_error'] * 100:.1f} %, max "
                      f"{s['max_abs_rel_error'] * 100:.1f} %")
    if report.plot is not None:
        console.print(f"wrote {report.plot}/slip_*.png and {report.plot / 'slip_rate.json'}")


def slip_rate_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file with events and slip "
                                         "annotations.", metavar="FILE", show_default=False)],
    rois: Annotated[Path | None, typer.Option(
        help="ROI + optics config: YAML (configs/rois_marker_scene.yaml) or a scene's "
             "scene.json. Without it the ROIs are proposed from each trial's slip-region "
             "events and the optics come from the sensor's attributes.",
        metavar="FILE", show_default=False)] = None,
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial to measure; repeatable (default: every trial with "
        "events).", metavar="TRIAL", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    plot: Annotated[Path | None, typer.Option(
        help="Folder for one Fig. 23-style PNG per trial (centroid, velocity, displacement) "
             "and slip_rate.json.", metavar="FOLDER", show_default=False)] = None,
) -> None:
    """Slip speed (m/s) and displacement (m) per trial from the event-weighted centroids of
    the marker-strip ROIs (paper 000, eqs. 19-21, Fig. 23): the slope of a line fitted to the
    centroid's y over the slip region, converted to metres by the optics (eqs. 3, 15), with
    standard errors; the truth is shown when the trial labels carry slip_speed_m_s."""

    def body() -> None:
        from ..spatial.pipeline import slip_rate_report

        report = slip_rate_report(file, rois, trials=trial, plot=plot)
        if as_json:
            typer.echo(json.dumps(report.as_dict(), indent=2, allow_nan=False))
        else:
            _print(report, title=f"Slip rate of {file} (speed = |slope of centroid y| over "
                   "the slip region)")

    run_guarded(body, flags=FLAGS)
