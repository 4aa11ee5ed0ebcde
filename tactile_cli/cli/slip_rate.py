"""`tactile slip-rate FILE`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded, spell
from ._options import JsonOption
from ._output import print_blocks

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``):
#: the library takes the ROIs and optics as ``config``, this command as the --rois file.
FLAGS: dict[str, Flag] = {"config": "--rois"}


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
    as_json: JsonOption = False,
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
        from ..spatial.text import slip_rate_blocks

        report = slip_rate_report(file, rois, trials=trial, plot=plot)
        if as_json:
            typer.echo(json.dumps(report.as_dict(), indent=2, allow_nan=False))
        else:
            print_blocks(slip_rate_blocks(
                report, title=f"Slip rate of {file} (speed = |slope of centroid y| over the "
                "slip region)", spell=lambda text: spell(text, FLAGS)), width=160)

    run_guarded(body, flags=FLAGS)
