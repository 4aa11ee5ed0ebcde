"""`tactile monitor FILE`: replay visuotactile trials through the slip-avoidance monitor
(paper 002, sec. V) and log its mode changes and grip commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {
    "source": "--source", "model_run": "--model", "stride": "--stride", "mesh": "--mesh",
    "hold_s": "--hold-s",
    "motion_s": "--motion-s", "threshold": "--threshold", "n_static": "--n-static",
    "trials": "--trial", "plot": "--plot",
}


def _ingest_frames(inputs: Path, out: Path, options: dict[str, Any]) -> Path:
    """Image-sequence folders into a tactile file, as `tactile ingest` would (``options``:
    the format's options plus ``trial_labels`` and ``annotations``)."""
    from ..ingest import ingest

    opts = dict(options)
    return ingest([inputs], out, format="images", trial_labels=opts.pop("trial_labels", None),
                  annotations=opts.pop("annotations", None), options=opts)


def monitor_command(
    file: Annotated[Path, typer.Argument(
        help="Tactile HDF5 file of visuotactile trials (ingested image-sequence folders), or a "
        "folder of frames: an image-sequence folder, a folder of them, or a scene folder of "
        "tactile simulate digit-avoidance / digit-press (its labels, annotations and px_per_mm "
        "are used).", metavar="INPUT", show_default=False)],
    source: Annotated[str, typer.Option("--source", help="Slip-signal source: intensity "
                                        "(colour change from the reference, no model) or "
                                        "height (needs --model).")] = "intensity",
    model: Annotated[Path | None, typer.Option(
        "--model", help="Run folder of a trained normal network (tactile train "
        "configs/train_mlp_normals.yaml), for --source height.", metavar="RUN")] = None,
    stride: Annotated[int, typer.Option(
        "--stride", min=1, help="For --source height: height maps from one network "
        "prediction per STRIDE x STRIDE pixel block (block-mean colour) and a Poisson solve "
        "on the blocks, interpolated back to every pixel; about STRIDE^2 less work, its "
        "height RMSE cost in benchmarks/RESULTS.md.", metavar="STRIDE")] = 1,
    mesh: Annotated[str, typer.Option("--mesh", help="Tactile mesh COLSxROWS (paper: 32x24).",
                                      metavar="COLSxROWS")] = "32x24",
    hold_s: Annotated[float, typer.Option("--hold-s", help="Seconds without a slip before the "
                                          "grip is released (paper: 3).")] = 3.0,
    motion_s: Annotated[float, typer.Option("--motion-s", help="Seconds the gripper moves "
                                            "after each grip command, when the trial has no "
                                            "gripper_moving annotations.")] = 0.5,
    threshold: Annotated[float | None, typer.Option(
        "--threshold", help="Fixed slip threshold; default: the adaptive one (2 x the mean "
        "of the first --n-static signals).")] = None,
    n_static: Annotated[int, typer.Option("--n-static", min=1, help="Static slip signals "
                                          "averaged by the adaptive threshold.")] = 30,
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", help="Replay only this trial (repeatable).", metavar="NAME")] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Write one PNG per trial (signal, threshold, modes, commands; like Fig. "
        "14) into this folder (created).", metavar="FOLDER")] = None,
    overwrite: Annotated[bool, typer.Option(
        help="Empty the --plot folder first (default: add the PNGs to it, replacing "
        "same-named ones).")] = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Replay each trial's frames through the monitor: slip signal on the tactile mesh,
    adaptive threshold from the first static second, no-slip/slip modes, raise grip on
    slip, release after --hold-s without one, the signal ignored while the gripper moves.
    Prints one line per mode change and grip command (or JSON) and, where the truth is
    known (interference annotations, or slip/slip_onset_s labels), the slips caught,
    missed and false and the detection delay. A folder of frames is first ingested into a
    temporary file (as tactile ingest would), then replayed the same way."""

    from ..visuotactile.monitor_replay import monitor_input

    def body():
        with RichProgress(enabled=progress) as bar:
            return monitor_input(file, ingest_frames=_ingest_frames, plot=plot,
                                 overwrite=overwrite, source=source, model_run=model,
                                 mesh=mesh, hold_s=hold_s, motion_s=motion_s,
                                 threshold=threshold, n_static=n_static, trials=trial,
                                 stride=stride, progress=bar)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json)
