"""`tactile heightmap FILE --model RUN --out FILE`: height maps of every frame (paper 002,
sec. II-B, eq. 9 and the Poisson integration; Fig. 2)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {
    "run_dir": "--model", "out": "--out", "truth_dir": "--truth", "px_per_mm": "--px-per-mm",
    "skip_below": "--skip-below", "stride": "--stride", "workers": "--workers",
    "trials": "--trial", "plot": "--plot",
    "overwrite": "--overwrite",
}


def heightmap_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file with frames (an ingested "
                                         "image sequence).", metavar="FILE",
                                         show_default=False)],
    model: Annotated[Path, typer.Option("--model", help="Run folder of the normal network "
                                        "(tactile train configs/train_mlp_normals.yaml).",
                                        metavar="RUN", show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output HDF5 file: stream "
                                      "height_mm per trial.", metavar="FILE",
                                      show_default=False)],
    truth: Annotated[Path | None, typer.Option("--truth", help="A scene's truth/ folder "
                                               "(tactile simulate digit-press): report the "
                                               "height RMSE.", metavar="FOLDER",
                                               show_default=False)] = None,
    px_per_mm: Annotated[float | None, typer.Option(
        "--px-per-mm", help="Gel scale; default: the frames sensor's px_per_mm attribute.",
        show_default=False)] = None,
    skip_below: Annotated[float | None, typer.Option(
        "--skip-below", help="Take pixels whose colour differs from the reference by less "
        "than this (0-255, every channel) as flat without running the network (faster; see "
        "benchmarks/heightmap.py for its RMSE cost). Default: off.", show_default=False)] = None,
    stride: Annotated[int, typer.Option(
        "--stride", min=1, help="One network prediction per STRIDE x STRIDE pixel block "
        "(from the block's mean colour) and a Poisson solve on the blocks, the heights "
        "interpolated back to every pixel: about STRIDE^2 less work (camera rate), its "
        "height RMSE cost in benchmarks/RESULTS.md. Default: every pixel.",
        metavar="STRIDE")] = 1,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Threads (default: the usable CPUs, at most 8).",
        show_default=False)] = None,
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial to process; repeatable (default: every trial with "
        "frames).", metavar="TRIAL", show_default=False)] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Folder for one Fig. 2-style PNG per trial (the frame of largest "
        "height: image and 3-D height map).", metavar="FOLDER", show_default=False)] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Height maps (mm) of every frame: the MLP's surface normals per pixel, gradients by
    eq. 9 and a DST Poisson solve; written as a new tactile HDF5 file (stream height_mm
    per trial, the model run in its provenance). With --truth, the height RMSE."""

    from ..visuotactile.heightmap import heightmap_file

    def body():
        with RichProgress(enabled=progress) as bar:
            return heightmap_file(file, model, out, truth_dir=truth, px_per_mm=px_per_mm,
                                  skip_below=skip_below, stride=stride, workers=workers,
                                  trials=trial,
                                  overwrite=overwrite, progress=bar, plot=plot)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json)
