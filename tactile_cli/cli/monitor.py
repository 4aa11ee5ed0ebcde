"""`tactile monitor FILE`: replay visuotactile trials through the slip-avoidance monitor
(paper 002, sec. V) and log its mode changes and grip commands."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ._errors import Flag, run_guarded
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"source": "--source", "model_run": "--model", "mesh": "--mesh",
                          "hold_s": "--hold-s", "motion_s": "--motion-s",
                          "threshold": "--threshold", "n_static": "--n-static",
                          "trials": "--trial", "plot": "--plot"}


def _ingest_frames(inputs: Path, out: Path, options: dict[str, Any]) -> Path:
    """Image-sequence folders into a tactile file, as `tactile ingest` would."""
    from ..ingest import IngestOptions, ingest

    return ingest([inputs], out, options=IngestOptions(format="images", **options))


def monitor_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file of visuotactile trials "
                                         "(ingested image-sequence folders), or a folder of "
                                         "frames: an image-sequence folder, a folder of them, "
                                         "or a scene folder of tactile simulate "
                                         "digit-avoidance / digit-press (its labels, "
                                         "annotations and px_per_mm are used).",
                                         metavar="INPUT", show_default=False)],
    source: Annotated[str, typer.Option("--source", help="Slip-signal source: intensity "
                                        "(colour change from the reference, no model) or "
                                        "height (needs --model).")] = "intensity",
    model: Annotated[Path | None, typer.Option("--model", help="Run folder of a trained "
                                               "normal network (tactile train "
                                               "configs/train_mlp_normals.yaml), for "
                                               "--source height.", metavar="RUN")] = None,
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
    plot: Annotated[Path | None, typer.Option("--plot", help="Write one PNG per trial (signal, "
                                              "threshold, modes, commands; like Fig. 14) "
                                              "into this folder (created).",
                                              metavar="FOLDER")] = None,
    overwrite: Annotated[bool, typer.Option(
        help="Empty the --plot folder first (default: add the PNGs to it, replacing "
        "same-named ones).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
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
                                 progress=bar)

    result = run_guarded(body, flags=FLAGS)
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2))
        return
    for t in result.trials:
        typer.echo(f"{t.trial}: threshold {t.threshold:.6g} (monitor from frame "
                   f"{t.start_frame}; gripper motion from {t.motion_from})")
        for e in t.events:
            if e.kind in ("slip", "no_slip", "raise_grip", "release_grip"):
                typer.echo(f"  {e.t_s:8.3f} s  frame {e.frame:5d}  {e.kind:<12} {e.detail}")
        ignored = sum(1 for e in t.events if e.kind == "ignored_moving")
        restarts = sum(1 for e in t.events if e.kind == "timer_restart")
        line = f"  {restarts} timer restarts, {ignored} frames above threshold ignored " \
               "while the gripper moved"
        if t.score is not None:
            s = t.score
            delay = (f", mean delay {1e3 * sum(s.delays_s) / len(s.delays_s):.0f} ms"
                     if s.delays_s else "")
            line += (f"; truth: {s.caught}/{s.n_interferences} caught, {s.missed} "
                     f"missed, {s.false_slips} false slips{delay}")
        typer.echo(line)
    tot = result.totals()
    if tot["trials_scored"]:
        rate = tot["detection_rate"]
        typer.echo(f"all: {tot['caught']}/{tot['interferences']} interferences caught"
                   + (f" ({100 * rate:.0f} %)" if rate is not None else "")
                   + f", {tot['false_slips']} false slips, {tot['raise_grip']} raise and "
                   f"{tot['release_grip']} release commands")
