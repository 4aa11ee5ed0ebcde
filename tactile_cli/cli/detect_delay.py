"""`tactile detect-delay RUN --data FILE`: how long a trained run needs to detect slippage."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded

FLAGS: dict[str, Flag] = {"data_paths": "--data", "stride": "--stride", "split": "--split"}


def detect_delay_command(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(help="Run folder of `tactile train` with a `motion` "
                                             "head.", show_default=False, metavar="RUN")],
    data: Annotated[
        list[Path], typer.Option("--data", "-d", help="Prepared HDF5 file(s) "
                                 "(`tactile accel-prepare`).", show_default=False,
                                 metavar="FILE")
    ],
    stride: Annotated[int, typer.Option(min=1, help="Samples between window ends (paper: 5).")
                      ] = 5,
    split: Annotated[str, typer.Option(help="test: the run's test trials (or, for other data, "
                                       "those its split rule holds out); all: every trial.")
                     ] = "test",
    threads: Annotated[int, typer.Option(min=1, help="torch threads for the inference time.")
                       ] = 1,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
) -> None:
    """Detection delay of slippage (paper 001, sec. 6.5): slip samples the run needs before
    it says slip (delay 1, ms) plus its inference time at batch 1 on this CPU (delay 2).

    JSON keys: delay_samples_ms, inference_ms, total_ms, motion_accuracy, n_onsets, missed,
    missed_long (missed among slips lasting at least one window), delay_long_ms (delay 1 over
    those slips).
    """

    def body() -> None:
        from ..accel.delay import detection_delay
        from ..errors import InputError

        if split not in ("test", "all"):
            raise InputError(f"--split must be test or all, got {split!r}")
        paths = [*data, *(Path(a) for a in ctx.args)]
        result = detection_delay(run, paths, stride=stride, split=split,  # type: ignore[arg-type]
                                 threads=threads)
        out = result.as_dict()
        if as_json:
            typer.echo(json.dumps(out, indent=2))
            return
        typer.echo(f"slip detected after {out['delay_samples']:.1f} samples = "
                   f"{out['delay_samples_ms']:.2f} ms (+ inference {out['inference_ms']:.2f} ms)"
                   f" = {out['total_ms']:.2f} ms (mean over the detected onsets); "
                   f"{out['n_detected']}/{out['n_onsets']} onsets detected, "
                   f"{out['n_detected_long']}/{out['n_onsets_long']} of the slips lasting at "
                   f"least one window ({out['window']} samples)"
                   + (f", after {out['delay_long_ms']:.2f} ms on those"
                      if out["delay_long_ms"] is not None else "")
                   + f"; motion accuracy {100 * out['motion_accuracy']:.1f} % over "
                   f"{out['n_windows']} windows (stride {stride})")

    run_guarded(body, flags=FLAGS)
