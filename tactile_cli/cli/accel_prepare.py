"""`tactile accel-prepare IN.h5 --out OUT.h5`: accel-tree recordings as training segments."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from .progress import RichProgress

FLAGS: dict[str, Flag] = {"segment_s": "--segment-s", "cutoff_hz": "--cutoff-hz"}


def accel_prepare_command(
    src: Annotated[Path, typer.Argument(help="File of `tactile ingest --format accel-tree`.",
                                        show_default=False, metavar="FILE")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output HDF5 file.",
                                      show_default=False, metavar="FILE")],
    segment_s: Annotated[float, typer.Option(help="Seconds per segment (one trial each, "
                                                  "label `segment`).")] = 2.0,
    cutoff_hz: Annotated[float | None, typer.Option(
        help="Band-limit the accelerations to this cut-off (anti-alias filter, resample to "
             "2 x cut-off and back).")] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    progress: Annotated[bool | None, typer.Option(
        "--progress/--no-progress", help="Show a progress bar (default: when stderr is a "
        "terminal).", show_default=False)] = None,
) -> None:
    """Cut accelerometer recordings into segments (trials labelled `segment`, for the
    80/10/10 split by segment), add the per-sample `speed_cm_s` target and optionally limit
    the bandwidth (paper 001, secs. 4 and 6.4)."""

    def body() -> None:
        from ..accel.prepare import prepare_file

        with RichProgress(enabled=progress) as bar:
            result = prepare_file(src, out, segment_s=segment_s, cutoff_hz=cutoff_hz,
                                  overwrite=overwrite, progress=bar)
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2))
            return
        typer.echo(f"wrote {result.out}: {result.n_segments} segments of {segment_s:g} s from "
                   f"{result.n_recordings} recordings"
                   + (f", band-limited to {cutoff_hz:g} Hz" if cutoff_hz else ""))

    run_guarded(body, flags=FLAGS)
