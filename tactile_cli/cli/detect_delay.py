"""`tactile detect-delay RUN --data FILE`: how long a trained run needs to detect slippage."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption, data_files

FLAGS: dict[str, Flag] = {"data_paths": "--data"}


def detect_delay_command(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(help="Run folder of `tactile train` with a `motion` "
                                             "head.", show_default=False, metavar="RUN")],
    data: Annotated[list[Path], typer.Option(
        "--data", "-d", help="Prepared HDF5 file(s) (`tactile accel-prepare`).",
        show_default=False, metavar="FILE")],
    stride: Annotated[int, typer.Option(min=1, help="Samples between window ends (paper: 5).")
                      ] = 5,
    split: Annotated[str, typer.Option(help="test: the run's test trials (or, for other data, "
                                       "those its split rule holds out); all: every trial.")
                     ] = "test",
    threads: Annotated[int, typer.Option(min=1, help="torch threads for the inference time.")
                       ] = 1,
    as_json: JsonOption = False,
) -> None:
    """Detection delay of slippage (paper 001, sec. 6.5): slip samples the run needs before
    it says slip (delay 1, ms) plus its inference time at batch 1 on this CPU (delay 2).

    JSON keys: delay_samples_ms, inference_ms, total_ms, motion_accuracy, n_onsets, missed,
    missed_long (missed among slips lasting at least one window), delay_long_ms (delay 1 over
    those slips).
    """

    def body() -> None:
        from ..accel.delay import detection_delay

        result = detection_delay(run, data_files(data, ctx), stride=stride,
                                 split=split, threads=threads)  # type: ignore[arg-type]
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2))
        else:
            typer.echo(result.summary())

    run_guarded(body, flags=FLAGS)
