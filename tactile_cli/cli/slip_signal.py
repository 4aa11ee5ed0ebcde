"""`tactile slip-signal FILE`: the slip signal of eq. 10 on a tactile mesh, its adaptive
threshold and the slip decision per trial (paper 002, secs. III-V; Figs. 5, 7, 10, 11)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"source": "--source", "run_dir": "--model", "mesh": "--mesh",
                          "scale": "--scale", "n_static": "--n-static", "trials": "--trial",
                          "px_per_mm": "--px-per-mm", "workers": "--workers", "plot": "--plot"}


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
    scale: Annotated[float, typer.Option(
        "--scale", help="Threshold = scale x mean of the static signals (paper: 2).")] = 2.0,
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
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Folder for one PNG per trial and source: S over time with the "
        "threshold, onset and detection.", metavar="FOLDER", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON (per "
                                          "trial the signal too).")] = False,
    progress: ProgressOption = None,
) -> None:
    """Slip signal S = sum |h_t - h_(t-1)| over a tactile mesh (eq. 10), adaptive threshold
    (scale x the mean of the first static signals) and, per trial, whether and when slip
    was detected. With slip/no_slip trial labels: detection rate, false alarms (a crossing
    before the labelled slip_onset_s, or on a no_slip trial) and the threshold scale that
    separates them best."""

    from ..visuotactile.monitor_replay import parse_mesh
    from ..visuotactile.slip import slip_signal_file

    def body():
        with RichProgress(enabled=progress) as bar:
            return slip_signal_file(file, source=source, run_dir=model, mesh=parse_mesh(mesh),
                                    scale=scale, n_static=n_static, trials=trial,
                                    px_per_mm=px_per_mm, workers=workers, progress=bar,
                                    plot=plot)

    result = run_guarded(body, flags=FLAGS)
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2, allow_nan=False))
        return
    _print(result, f"Slip signal of {file} (mesh {mesh}, threshold {scale:g} x mean of "
           f"{n_static} static signals)")
    if plot is not None:
        typer.echo(f"wrote {plot}/slip_*.png")


def _verdict(r) -> str:
    if r.score is None:
        return "-"
    if r.score.false_alarm:
        return "hit + false alarm" if r.score.detected else "false alarm"
    return "hit" if r.score.detected else "missed" if r.slip else "correct reject"


def _print(result, title: str) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console(width=None if sys.stdout.isatty() else 160)
    table = Table(title=title)
    for col in ("trial", "object", "source", "label", "onset (s)", "threshold",
                "detected at (s)", "peak/static", "result"):
        table.add_column(col)
    for r in result.trials:
        d = r.detection
        table.add_row(r.trial, r.object or "-", r.source,
                      "-" if r.slip is None else ("slip" if r.slip else "no_slip"),
                      "-" if r.onset_s is None else f"{r.onset_s:.3f}", f"{d.threshold:.4g}",
                      "-" if d.first_time_s is None else f"{d.first_time_s:.3f}",
                      f"{d.peak_ratio():.1f}", _verdict(r))
    console.print(table)
    for src, rates in result.rates.items():
        best = result.best[src]
        console.print(f"{src}: detection rate {rates.detection_rate:.2f} over "
                      f"{rates.n_slip} slip trials, false alarms {rates.false_alarms} of "
                      f"{rates.n_slip + rates.n_no_slip} trials; best scale {best.scale:g} "
                      f"(as good: {best.best_from:g}-{best.best_to:g}; detection "
                      f"{best.rates.detection_rate:.2f}, false alarms "
                      f"{best.rates.false_alarms})")
