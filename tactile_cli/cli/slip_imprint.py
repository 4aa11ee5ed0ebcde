"""`tactile slip-imprint FILE`: whether the grasp's contact imprint survived the lift, per
trial, with a threshold given or learned from labelled trials by leave-one-object-out CV."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {
    "mesh": "--mesh", "grasp_part": "--grasp-part", "threshold": "--threshold",
    "label": "--label", "baseline": "--baseline", "trials": "--trial", "plot": "--plot",
    "overwrite": "--overwrite",
}


def slip_imprint_command(
    file: Annotated[Path, typer.Argument(help="Ingested frames file (tactile ingest ... "
                                         "--reference first).", metavar="FILE",
                                         show_default=False)],
    mesh: Annotated[str, typer.Option(
        "--mesh", help="Mesh COLSxROWS of the area means the imprint is compared on.",
        metavar="COLSxROWS")] = "32x24",
    grasp_part: Annotated[float, typer.Option(
        "--grasp-part", help="Share of each trial's frames within which the grasp is "
        "complete; its strongest imprint is the grasp frame.", metavar="SHARE",
        show_default="2/3")] = 2 / 3,
    threshold: Annotated[str, typer.Option(
        "--threshold", help="Imprint change 1 - r above which a trial slipped, or auto: "
        "learned from the labelled trials by leave-one-object-out CV and reported with its "
        "held-out accuracy and interval.", metavar="CHANGE|auto")] = "auto",
    label: Annotated[str, typer.Option(
        "--label", help="Trial label saying slipped (slip, fail, 1, ...) or held (no_slip, "
        "ok, 0, ...).", metavar="LABEL")] = "slip",
    baseline: Annotated[str, typer.Option(
        "--baseline", help="Maps relative to: first (the trial's first frame, before "
        "contact; robust to a reference frame taken at another time) or reference (the "
        "stored reference frame as it is).", metavar="first|reference")] = "first",
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial; repeatable (default: every trial).", metavar="TRIAL",
        show_default=False)] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="PNG: retention over time per trial and each change against the "
        "threshold.", metavar="FILE", show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace --plot.")] = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Imprint retention: the grasp frame is the strongest imprint (mean colour change from
    the reference) within the first --grasp-part of a trial; the retention is the
    correlation of each later frame's change with it over the mesh, and a trial slipped
    when 1 - retention at its last frame is above the threshold. A held object's imprint
    stays and deepens; a slipping one slides or fades. For lifts, where the slip signal's
    size cannot tell held from slipped (every lift moves the gel)."""

    from ..visuotactile.imprint import THRESHOLD_AUTO, slip_imprint_file
    from ..visuotactile.monitor_replay import parse_mesh

    def body():
        text = threshold.strip().lower()
        if text == THRESHOLD_AUTO:
            value: float | str = THRESHOLD_AUTO
        else:
            try:
                value = float(text)
            except ValueError:
                value = text
        with RichProgress(enabled=progress) as bar:
            return slip_imprint_file(file, mesh=parse_mesh(mesh), grasp_part=grasp_part,
                                     threshold=value, label=label, baseline=baseline,
                                     trials=trial,
                                     progress=bar, plot=plot, overwrite=overwrite)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json,
                 width=None if sys.stdout.isatty() else 160)
