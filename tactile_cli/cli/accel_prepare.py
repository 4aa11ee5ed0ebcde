"""`tactile accel-prepare IN.h5 --out OUT.h5` (or `IN.h5... --out-dir FOLDER` on Dask):
accel-tree recordings as training segments."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption, run_file_batch
from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {**BATCH_FLAGS}


def accel_prepare_command(
    inputs: Annotated[list[Path], typer.Argument(
        help="File(s) of `tactile ingest --format accel-tree`; several go with --out-dir.",
        show_default=False, metavar="FILE")],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Output HDF5 file (one "
                                             "input).", show_default=False,
                                             metavar="FILE")] = None,
    out_dir: Annotated[Path | None, typer.Option(
        "--out-dir", help="Folder for one output per input, <input stem>.h5, prepared one "
        "task per file on Dask (--workers, --scheduler); outputs newer than their input are "
        "skipped.", show_default=False, metavar="FOLDER")] = None,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    segment_s: Annotated[float, typer.Option(help="Seconds per segment (one trial each, "
                                                  "label `segment`).")] = 2.0,
    cutoff_hz: Annotated[float | None, typer.Option(
        help="Band-limit the accelerations to this cut-off (anti-alias filter, resample to "
             "2 x cut-off and back).")] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file (with "
                                            "--out-dir: prepare up-to-date inputs again).")
                         ] = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Cut accelerometer recordings into segments (trials labelled `segment`, for the
    80/10/10 split by segment), add the per-sample `speed_cm_s` target and optionally limit
    the bandwidth (paper 001, secs. 4 and 6.4)."""

    from ..accel.prepare import prepare_file
    from ..accel.prepare_each import prepare_each

    def body():
        if (out is None) == (out_dir is None):
            raise InputError("give --out FILE (one input) or --out-dir FOLDER (one file per "
                             "input)")
        if out_dir is not None:
            return run_file_batch("accel-prepare", lambda **printing: prepare_each(
                inputs, out_dir, segment_s=segment_s, cutoff_hz=cutoff_hz, overwrite=overwrite,
                scheduler=scheduler, workers=workers, **printing), progress=progress,
                as_json=as_json, flags=FLAGS, todo="to prepare",
                describe=lambda item: f"-> {item.output} ({item.value['n_segments']} segments)")
        if len(inputs) > 1:
            raise InputError("--out takes one input; give --out-dir FOLDER for several",
                             path=inputs[1])
        if scheduler is not None or workers is not None:
            raise InputError("--scheduler and --workers go with --out-dir (one task per file)")
        with RichProgress(enabled=progress) as bar:
            return prepare_file(inputs[0], out, segment_s=segment_s, cutoff_hz=cutoff_hz,
                                overwrite=overwrite, progress=bar)

    result = run_guarded(body, flags=FLAGS)
    if out_dir is None:
        print_result(result, as_json=as_json)
