"""`tactile grade FILE... [--config C] [--json] [--plot DIR] [--calibrate --out NEW.yaml]`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_blocks

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {}


def grade_command(
    files: Annotated[list[Path], typer.Argument(
        help="Tactile HDF5 files (events or an event-count stream with a `net` channel) or "
             "CSV tables trial,area[,level].", metavar="FILE", show_default=False)],
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Grader YAML config (default: the marker-sensor config shipped "
        "with tactile, configs/grade_marker.yaml).", metavar="FILE", show_default=False)] = None,
    as_json: JsonOption = False,
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
        from ..grade.text import grade_blocks

        run = grade_files(files, config=config, label_key=label_key, plot=plot,
                          calibrate=calibrate, out=out, overlap=overlap, overwrite=overwrite)
        if as_json:
            typer.echo(json.dumps(run.as_dict(), indent=2))
        else:
            print_blocks(grade_blocks(run, multi_file=len({str(f) for f in files}) > 1),
                         width=160)

    run_guarded(body, flags=FLAGS)
