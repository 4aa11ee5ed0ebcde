"""`tactile accel-prepare IN.h5 --out OUT.h5` (or `IN.h5... --out-dir FOLDER` on Dask):
accel-tree recordings as training segments."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ._batch import BATCH_FLAGS, FileBatchPrinter, SchedulerOption, WorkersOption, finish_batch
from ._errors import COMMON_FLAGS, Flag, run_guarded, to_flags
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"segment_s": "--segment-s", "cutoff_hz": "--cutoff-hz",
                          "out": "--out", "out_dir": "--out-dir", **BATCH_FLAGS}


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
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Cut accelerometer recordings into segments (trials labelled `segment`, for the
    80/10/10 split by segment), add the per-sample `speed_cm_s` target and optionally limit
    the bandwidth (paper 001, secs. 4 and 6.4)."""

    from ..accel.prepare import prepare_file

    def body():
        if (out is None) == (out_dir is None):
            raise InputError("give --out FILE (one input) or --out-dir FOLDER (one file per "
                             "input)")
        if out_dir is not None:
            return _prepare_each(inputs, out_dir, segment_s=segment_s, cutoff_hz=cutoff_hz,
                                 overwrite=overwrite, scheduler=scheduler, workers=workers,
                                 progress=progress, as_json=as_json)
        if len(inputs) > 1:
            raise InputError("--out takes one input; give --out-dir FOLDER for several",
                             path=inputs[1])
        if scheduler is not None or workers is not None:
            raise InputError("--scheduler and --workers go with --out-dir (one task per file)")
        with RichProgress(enabled=progress) as bar:
            return prepare_file(inputs[0], out, segment_s=segment_s, cutoff_hz=cutoff_hz,
                                overwrite=overwrite, progress=bar)

    result = run_guarded(body, flags=FLAGS)
    if out_dir is not None:
        return
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2))
        return
    typer.echo(f"wrote {result.out}: {result.n_segments} segments of {segment_s:g} s from "
               f"{result.n_recordings} recordings"
               + (f", band-limited to {cutoff_hz:g} Hz" if cutoff_hz else ""))


def _prepare_each(inputs: list[Path], out_dir: Path, *, progress: bool | None, as_json: bool,
                  **settings: Any) -> None:
    from ..accel.prepare_each import prepare_each

    printer = FileBatchPrinter(
        "accel-prepare", progress=progress, todo="to prepare",
        describe=lambda item: f"-> {item.output} ({item.value['n_segments']} segments)",
        flags=lambda t: to_flags(t, {**COMMON_FLAGS, **FLAGS}))
    with printer.running():
        result = prepare_each(inputs, out_dir, on_plan=printer.on_plan,
                              on_progress=printer.on_progress, on_item=printer.on_item,
                              **settings)
    finish_batch(result, as_json=as_json)
