"""`tactile centroids FILE --rois CFG --out OUT.h5`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption
from .progress import ProgressOption, RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"config": "--rois"}


def centroids_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file with event trials.",
                                         metavar="FILE", show_default=False)],
    rois: Annotated[Path, typer.Option(
        help="ROI config: YAML (configs/rois_marker_scene.yaml) or a scene's scene.json; its "
             "centroid section sets polarity, median filter and bin width.",
        metavar="FILE", show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output HDF5 file.", metavar="FILE",
                                      show_default=False)],
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial to convert; repeatable (default: every trial with "
        "events).", metavar="TRIAL", show_default=False)] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """ROI centroid trajectories (paper 000, sec. 5.2, eq. 19) as a signal stream for
    `tactile train`/`evaluate`: per trial /trials/{t}/signals/roi_centroids with each ROI's
    event-weighted centroid x, y (px) per bin, filled with the ROI centre and flagged 0 in
    the ROI's <name>_has_events channel where it had no events, its event count, and
    per-bin action labels from the annotations."""

    def body() -> None:
        from ..spatial.stream import write_centroid_file

        with RichProgress(enabled=progress) as bar:
            result = write_centroid_file(file, out, rois, trials=trial, overwrite=overwrite,
                                         progress=bar)
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2, allow_nan=False))
            return
        measured = [t.measured_fraction for t in result.trials]
        typer.echo(f"wrote {result.path}: {len(result.trials)} trial(s), "
                   f"{len(result.rois)} ROI(s), {result.bin_s * 1e3:g} ms bins; centroids "
                   f"measured in {100 * sum(measured) / len(measured):.1f} % of (bin, ROI) "
                   "cells, the rest filled with the ROI centre")

    run_guarded(body, flags=FLAGS)
