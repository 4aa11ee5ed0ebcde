"""`tactile ingest INPUT... --out FILE`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..ingest import FORMATS, IngestOptions, ingest, parse_labels
from ..store.writer import Compression
from ._errors import Flag, run_guarded
from .progress import RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "format": "--format",
    "mapping": "--mapping",
    "labels": "--label",
    "width_px": "--width",
    "height_px": "--height",
    "annotations": "--annotations",
    "trial_labels": "--trial-labels",
}


def ingest_command(
    inputs: Annotated[
        list[Path], typer.Argument(help="Raw recordings: files or folders.", show_default=False)
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output HDF5 file.", show_default=False)],
    fmt: Annotated[
        str, typer.Option("--format", "-f", help=f"Input format: auto, {', '.join(FORMATS)}.")
    ] = "auto",
    mapping: Annotated[
        Path | None,
        typer.Option(help="YAML mapping file for sensor CSVs (see configs/mapping_example.yaml)."),
    ] = None,
    label: Annotated[
        list[str] | None,
        typer.Option("--label", "-l", help="key=value label added to every trial; repeatable."),
    ] = None,
    width: Annotated[
        int | None, typer.Option(help="Event sensor width in px (CSV/NPY events).")
    ] = None,
    height: Annotated[
        int | None, typer.Option(help="Event sensor height in px (CSV/NPY events).")
    ] = None,
    sensor: Annotated[
        str | None, typer.Option(help="Sensor name to record (default from the input).")
    ] = None,
    fps: Annotated[
        float | None,
        typer.Option(
            min=0.001, help="Frame rate of image folders without a timestamps.csv (default 30)."
        ),
    ] = None,
    annotations: Annotated[
        Path | None,
        typer.Option(
            help="CSV of time intervals per trial (columns trial,start_s,end_s,label), "
            "stored as /trials/<trial>/annotations.",
        ),
    ] = None,
    trial_labels: Annotated[
        Path | None,
        typer.Option(
            help="CSV with a 'trial' column; every other column becomes a label of that "
            "trial (numbers as numbers, empty cells skipped).",
        ),
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file.")] = False,
    compression: Annotated[
        int,
        typer.Option(
            min=-1, max=9, help="gzip level 0-9 for data datasets; -1 stores them uncompressed."
        ),
    ] = 1,
    progress: Annotated[
        bool | None,
        typer.Option(
            "--progress/--no-progress",
            help="Show a progress bar (default: when stderr is a terminal).",
            show_default=False,
        ),
    ] = None,
) -> None:
    """Ingest raw recordings into one validated tactile HDF5 file (trials as groups).

    Formats: AEDAT4 event files, event CSV (t,x,y,p) and NPY structured arrays, the
    accelerometer CSV tree (object/orientation/speed folders), any sensor CSV described by
    a YAML mapping file, and image-sequence folders of visuotactile sensors. Trials are
    named after the input files (stems); --annotations and --trial-labels add ground truth
    keyed by those names. The output is written to a temporary file and renamed into place
    only when complete and valid.
    """

    def body() -> None:
        options = IngestOptions(
            format=fmt,
            mapping=mapping,
            labels=parse_labels(label or []),
            width_px=width,
            height_px=height,
            sensor_name=sensor,
            frame_rate_hz=fps,
            annotations=annotations,
            trial_labels=trial_labels,
        )
        with RichProgress(enabled=progress) as bar:
            path = ingest(
                inputs,
                out,
                options=options,
                overwrite=overwrite,
                compression=Compression(None if compression < 0 else compression),
                progress=bar,
            )
        typer.echo(f"wrote {path}")

    run_guarded(body, flags=FLAGS)
