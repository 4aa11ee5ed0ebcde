"""`tactile ingest INPUT... --out FILE` and `tactile ingest INPUT... --out-dir FOLDER
[--workers N] [--scheduler ADDRESS] [--json]`"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ..ingest import FORMATS, ingest, parse_labels, parse_options
from ..ingest.registry import formats_taking, option_names
from ..store.writer import Compression
from ._batch import BATCH_FLAGS, run_file_batch, scheduler_option, workers_option
from ._errors import Flag, run_guarded, spell
from ._ingest_flags import OPTION_FLAGS
from .progress import ProgressOption, RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "format": "--format", **OPTION_FLAGS, "options": "--option", "labels": "--label",
    "annotations": "--annotations", "trial_labels": "--trial-labels", "out": "--out",
    "out_dir": "--out-dir", **BATCH_FLAGS, "json": "--json",
}
OutDirScheduler = scheduler_option("--out-dir: ")
OutDirWorkers = workers_option("--out-dir: ")


def _formats(option: str) -> str:
    """`` (formats: aedat4, images)``: the formats of the registry that take ``option``."""
    return f" Formats: {', '.join(formats_taking(option))}."


def _format_help() -> str:
    return ("Input format (default auto: told from the inputs): "
            + "; ".join(f"{f.name}: {f.summary}" for f in FORMATS.values()) + ".")


def _option_help() -> str:
    others = {k: v for k, v in option_names().items() if k not in OPTION_FLAGS}
    listed = "; ".join(f"{k} ({', '.join(v)})" for k, v in others.items())
    return ("A format option by its name, KEY=VALUE (repeatable), for the options without a "
            f"flag of their own: {listed}.")


def ingest_command(
    inputs: Annotated[list[Path], typer.Argument(
        help="Raw recordings: files or folders.", metavar="INPUT", show_default=False)],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output HDF5 file (all inputs into one).", metavar="FILE",
        show_default=False)] = None,
    out_dir: Annotated[Path | None, typer.Option(
        "--out-dir", help="Folder for one HDF5 file per input, FOLDER/<input stem>.h5, ingested "
        "on Dask; outputs newer than their inputs are skipped (unless --overwrite); a failed "
        "input does not stop the others (exit 2).", metavar="FOLDER", show_default=False)] = None,
    fmt: Annotated[str, typer.Option(
        "--format", "-f", help=_format_help(), metavar="NAME")] = "auto",
    mapping: Annotated[Path | None, typer.Option(
        help="YAML mapping file for sensor CSVs (see configs/mapping_example.yaml) or the "
        "topics of a ROS bag/MCAP (configs/rosbag_tactile_rig.yaml)." + _formats("mapping"),
        metavar="FILE")] = None,
    label: Annotated[list[str] | None, typer.Option(
        "--label", "-l", help="key=value label added to every trial; repeatable.",
        metavar="KEY=VALUE")] = None,
    width: Annotated[int | None, typer.Option(
        help="Event sensor width in px (CSV/NPY events; checked against AEDAT4 files and "
        "frames)." + _formats("width_px"))] = None,
    height: Annotated[int | None, typer.Option(
        help="Event sensor height in px (CSV/NPY events; checked against AEDAT4 files and "
        "frames)." + _formats("height_px"))] = None,
    sensor: Annotated[str | None, typer.Option(
        help="Sensor name to record (default from the input)." + _formats("sensor_name"))] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", "-O", help=_option_help(), metavar="KEY=VALUE")] = None,
    fps: Annotated[float | None, typer.Option(
        min=0.001, metavar="HZ", help="Frame rate of image folders without a timestamps.csv "
        "(default: 30 Hz assumed, with a note)." + _formats("frame_rate_hz"))] = None,
    reference: Annotated[str | None, typer.Option(
        "--reference", metavar="first|NAME", help="Image folders: the no-contact reference "
        "frame of every folder: 'first' (the first frame in natural order, kept as frame 0) "
        "or a file name or stem in each folder (default: the file named reference, ref, "
        "background or no_contact)." + _formats("reference"))] = None,
    px_per_mm: Annotated[float | None, typer.Option(
        "--px-per-mm", min=0.0, metavar="PX", help="Image folders: pixels per millimetre on "
        "the gel (DIGIT-like: 16), stored as the sensor attribute px_per_mm for calibration "
        "and height maps." + _formats("px_per_mm"))] = None,
    trials_from: Annotated[Path | None, typer.Option(
        "--trials-from", metavar="FILE", help="Robot recordings: CSV of trial time ranges "
        "(start_s,end_s[,trial,labels...], seconds from the recording's first message)."
        + _formats("trials_from"))] = None,
    annotations: Annotated[Path | None, typer.Option(
        help="CSV of time intervals per trial (columns trial,start_s,end_s,label), stored as "
        "/trials/<trial>/annotations.", metavar="FILE")] = None,
    trial_labels: Annotated[Path | None, typer.Option(
        help="CSV with a 'trial' column; every other column becomes a label of that trial "
        "(numbers as numbers, empty cells skipped), except 'split' (train, val or test), "
        "which sets the trial's split.", metavar="FILE")] = None,
    skip_unknown: Annotated[bool, typer.Option(
        "--skip-unknown", help="AEDAT4: leave out streams of a type tactile does not read "
        "(poses, bounding boxes, ...), with a note; without it such a file is refused."
        + _formats("skip_unknown"))] = False,
    sort_stamps: Annotated[bool, typer.Option(
        "--sort-stamps", help="Robot recordings: sort the samples and frames of a stream whose "
        "stamps go back (without it such a stream is refused, with the count)."
        + _formats("sort_stamps"))] = False,
    overwrite: Annotated[bool, typer.Option(
        help="Replace an existing output file (with --out-dir: ingest up-to-date inputs "
        "again).")] = False,
    scheduler: OutDirScheduler = None,
    workers: OutDirWorkers = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help="--out-dir: print every input's status as JSON.")] = False,
    compression: Annotated[int, typer.Option(
        min=-1, max=9, help="gzip level 0-9 for data datasets; -1 stores them uncompressed.")] = 1,
    progress: ProgressOption = None,
) -> None:
    """Ingest raw recordings into one validated tactile HDF5 file (trials as groups).

    Formats (--format, default told from the inputs; the table in
    tactile_cli/ingest/registry.py): AEDAT4 files, event CSV and NPY files, the
    accelerometer CSV tree, any sensor CSV described by a YAML mapping file (rows of a table
    as trials: `layout: rows`), and image-sequence folders of visuotactile sensors. Each
    format takes its own options (an option another format takes is refused, naming the
    formats that take it). Trials are named after the input files (stems) or folders;
    --annotations and --trial-labels add ground truth keyed by those names. The output is
    written to a temporary file and renamed into place only when complete and valid.
    Assumptions the file records (a frame rate for folders without timestamps, stamps a
    mapping's policy dropped or spread) are printed as notes on stderr.

    With --out-dir instead of --out, each input becomes its own file FOLDER/<input stem>.h5,
    ingested by Dask workers (--workers, --scheduler); outputs newer than their inputs are
    skipped, a failed input is reported on one line while the others are written, and the
    command exits 2 if any failed.
    """

    def body() -> None:
        if (out is None) == (out_dir is None):
            raise InputError("give `out` (one file for all inputs) or `out_dir` (one file "
                             "per input), " + ("not both" if out is not None else "one of them"))
        if out is not None and (scheduler is not None or workers is not None or as_json):
            raise InputError("`scheduler`, `workers` and `json` go with `out_dir` (one file "
                             "per input, on Dask); `out` writes one file in this process")
        labels = parse_labels(label or [])
        flagged = {"mapping": mapping, "width_px": width, "height_px": height,
                   "sensor_name": sensor, "frame_rate_hz": fps, "reference": reference,
                   "px_per_mm": px_per_mm, "skip_unknown": skip_unknown or None,
                   "trials_from": trials_from, "sort_stamps": sort_stamps or None}
        options = parse_options(option or [], flagged)
        level = Compression(None if compression < 0 else compression)
        if out_dir is not None:  # one file per input on Dask, a line per input; exit 2 on a failure
            from ..ingest.batch import ingest_each

            run_file_batch("ingest", lambda **printing: ingest_each(
                inputs, out_dir, format=fmt, options=options, labels=labels,
                annotations=annotations, trial_labels=trial_labels, overwrite=overwrite,
                compression=level, scheduler=scheduler, workers=workers, **printing),
                progress=progress, as_json=as_json, flags=FLAGS, todo="to ingest")
            return
        assert out is not None
        with RichProgress(enabled=progress) as bar:
            path = ingest(inputs, out, format=fmt, options=options, labels=labels,
                          annotations=annotations, trial_labels=trial_labels,
                          overwrite=overwrite, compression=level, progress=bar,
                          on_note=_print_note)
        typer.echo(f"wrote {path}")

    run_guarded(body, flags=FLAGS)


def _print_note(note: str) -> None:
    """A library note as one ``tactile: note:`` line on stderr, arguments spelt as flags."""
    print(f"tactile: note: {spell(note, FLAGS)}", file=sys.stderr)
