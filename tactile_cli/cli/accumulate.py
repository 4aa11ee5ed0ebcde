"""`tactile accumulate FILE`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..vocabulary import BIN_S
from ._errors import Flag, run_guarded, seconds_as_ms
from ._options import JsonOption
from ._output import print_blocks
from .progress import ProgressOption, RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "bin_s": ("--bin-ms", seconds_as_ms), "smooth_bins": "--smooth", "csv": "--csv",
}


def accumulate_command(
    file: Annotated[Path, typer.Argument(
        help="A tactile HDF5 file with event trials.", metavar="FILE", show_default=False)],
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t",
        help="Trial to accumulate; repeatable (default: every trial with events).",
        metavar="TRIAL", show_default=False)] = None,
    bin_ms: Annotated[float, typer.Option(
        "--bin-ms", min=0.001, help="Bin width in ms (paper: 20).")] = BIN_S * 1000,
    smooth: Annotated[int, typer.Option(
        "--smooth", min=1, help="Moving-average window in bins (odd).")] = 5,
    segment: Annotated[bool, typer.Option(
        "--segment", help="Find the approach/press/slip/release regions.")] = False,
    as_json: JsonOption = False,
    csv_out: Annotated[Path | None, typer.Option(
        "--csv", help="Write one row per bin (counts, smoothed net, actions).", metavar="FILE",
        show_default=False)] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Write the count streams to a new HDF5 file.", metavar="FILE",
        show_default=False)] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Folder for one Fig. 10-style PNG per trial (created).", metavar="FOLDER",
        show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace existing --out/--csv files.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Count events per polarity in fixed bins (20 ms), smooth the net count and, with
    --segment, find each trial's approach, press, slip and release regions (paper 000,
    sec. 4.2, Fig. 10). Prints one row per trial; with annotations in the file, the share
    of bins whose detected action matches them.
    """

    def body() -> None:
        # imported here: the library pulls in the FOS package, which `tactile --help` skips
        from ..events.recording import accumulate_file
        from ..events.text import accumulation_blocks

        with RichProgress(enabled=progress) as bar:
            run = accumulate_file(file, trials=trial or None, bin_s=bin_ms / 1000.0,
                                  smooth_bins=smooth, segment=segment, out=out, csv=csv_out,
                                  plot=plot, overwrite=overwrite, progress=bar)
        if as_json:
            typer.echo(json.dumps(run.as_dict(), indent=2, allow_nan=False))
        else:
            print_blocks(accumulation_blocks(
                run, title=f"{file}: {bin_ms:g} ms bins, moving average of {smooth}",
                plot=plot), width=160)

    run_guarded(body, flags=FLAGS)
