"""`tactile slip-signal FILE`: the slip signal of eq. 10 on a tactile mesh, its adaptive
threshold and the slip decision per trial (paper 002, secs. III-V; Figs. 5, 7, 10, 11)."""

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
    "source": "--source", "run_dir": "--model", "mesh": "--mesh", "scale": "--scale",
    "n_static": "--n-static", "trials": "--trial", "px_per_mm": "--px-per-mm",
    "workers": "--workers", "stride": "--stride", "plot": "--plot",
}


def slip_signal_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file: ingested frames, or the "
                                         "output of tactile heightmap.", metavar="FILE",
                                         show_default=False)],
    source: Annotated[str, typer.Option(
        "--source", help="Maps the signal is taken on: height (the file's height maps, or "
        "frames through --model), intensity (colour change from the reference frame; no "
        "calibration needed), both (side by side), auto (height when possible).")] = "auto",
    model: Annotated[Path | None, typer.Option(
        "--model", help="Run folder of the normal network, for --source height on a frames "
        "file.", metavar="RUN", show_default=False)] = None,
    mesh: Annotated[str, typer.Option(
        "--mesh", help="Tactile mesh COLSxROWS (paper: 320x240 ... 4x3). Default 32x24, the "
        "paper's: 768 units, dense enough for the small hex key of the scene "
        "(benchmarks/slip_mesh.py).", metavar="COLSxROWS")] = "32x24",
    scale: Annotated[str, typer.Option(
        "--scale", help="Threshold = scale x mean of the static signals (paper: 2), or auto: "
        "the scale learned from the slip/no_slip trials, chosen by leave-one-object-out CV "
        "(each trial its own group without an object label) and reported with its "
        "held-out accuracy and interval.", metavar="SCALE|auto")] = "2",
    n_static: Annotated[int, typer.Option(
        "--n-static", help="Static slip signals averaged for the threshold (paper: 30, one "
        "second at 30 Hz).")] = 30,
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial; repeatable (default: every trial).", metavar="TRIAL",
        show_default=False)] = None,
    px_per_mm: Annotated[float | None, typer.Option(
        "--px-per-mm", help="Gel scale for --model; default: the sensor's attribute.",
        show_default=False)] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Threads for --model (default: the usable CPUs).",
        show_default=False)] = None,
    stride: Annotated[int, typer.Option(
        "--stride", min=1, help="For --model: height maps from one network prediction per "
        "STRIDE x STRIDE pixel block, interpolated back to every pixel (as tactile heightmap "
        "--stride).", metavar="STRIDE")] = 1,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Folder for one PNG per trial and source: S over time with the "
        "threshold, onset and detection.", metavar="FOLDER", show_default=False)] = None,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Slip signal S = sum |h_t - h_(t-1)| over a tactile mesh (eq. 10), adaptive threshold
    (scale x the mean of the first static signals) and, per trial, whether and when slip
    was detected. With slip/no_slip trial labels: detection rate, false alarms (a crossing
    before the labelled slip_onset_s, or on a no_slip trial) and the threshold scale that
    separates them best. Each trial says whether its static frames were static (a lift is
    not: the threshold is then one on motion); --scale auto learns the scale instead."""

    from ..visuotactile.monitor_replay import parse_mesh
    from ..visuotactile.slip import parse_scale, slip_signal_file

    def body():
        with RichProgress(enabled=progress) as bar:
            return slip_signal_file(file, source=source, run_dir=model, mesh=parse_mesh(mesh),
                                    scale=parse_scale(scale), n_static=n_static, trials=trial,
                                    px_per_mm=px_per_mm, workers=workers, stride=stride,
                                    progress=bar, plot=plot)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json,
                 width=None if sys.stdout.isatty() else 160)
