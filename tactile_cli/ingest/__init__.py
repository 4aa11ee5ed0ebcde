"""`tactile ingest`: raw recordings of any supported format into one tactile HDF5 file.

Each format has its own module with one entry function
``ingest_<format>(inputs, writer, options, progress)`` that adds sensors and trials to a
:class:`~tactile_cli.store.StoreWriter` (and may return one-line notes for the user about
assumptions the file records). :func:`ingest` picks the format, opens the writer
(temporary file, validation, atomic rename), adds run-wide labels and then the ground-truth
sidecars (``--annotations``, ``--trial-labels``; see :mod:`tactile_cli.ingest.sidecars`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..config_file import missing_file_error
from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.writer import DEFAULT_COMPRESSION, Compression, StoreWriter

#: format name -> "module:function" (imported on use, so the CLI starts fast)
FORMATS: dict[str, str] = {
    "aedat4": "tactile_cli.ingest.events_aedat4:ingest_aedat4",
    "events-csv": "tactile_cli.ingest.events_table:ingest_events_csv",
    "events-npy": "tactile_cli.ingest.events_table:ingest_events_npy",
    "accel-tree": "tactile_cli.ingest.accel_tree:ingest_accel_tree",
    "mapped-csv": "tactile_cli.ingest.mapped_csv:ingest_mapped_csv",
    "images": "tactile_cli.ingest.image_sequence:ingest_image_sequence",
}

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg"}


@dataclass
class IngestOptions:
    """Options shared by all formats (each format reads the ones it needs)."""

    format: str = "auto"
    mapping: Path | None = None  # YAML mapping file for mapped-csv
    labels: dict[str, str | int | float] = field(default_factory=dict)  # added to every trial
    width_px: int | None = None  # event sensor geometry for CSV/NPY events
    height_px: int | None = None
    sensor_name: str | None = None
    chunk_events: int = 1 << 20  # events read per chunk while streaming
    frame_rate_hz: float | None = None  # image folders without timestamps.csv (default 30 Hz)
    annotations: Path | None = None  # CSV trial,start_s,end_s,label (see ingest.sidecars)
    trial_labels: Path | None = None  # CSV trial,<label>... (see ingest.sidecars)
    skip_unknown: bool = False  # AEDAT4: leave out streams of unknown type (else an error)
    reference: str | None = None  # image folders: "first" or a file name (default: by name)
    px_per_mm: float | None = None  # image folders: gel scale, stored as a sensor attribute

    def as_config(self) -> dict[str, Any]:
        out = asdict(self)
        for key in ("mapping", "annotations", "trial_labels"):
            value = getattr(self, key)
            out[key] = None if value is None else str(value)
        return out


def detect_format(inputs: Sequence[Path], options: IngestOptions) -> str:
    """The format of the inputs: explicit ``options.format`` or inferred from them."""
    if options.format != "auto":
        if options.format not in FORMATS:
            raise InputError(f"unknown format {options.format!r}; use one of: {', '.join(FORMATS)}")
        return options.format
    if options.mapping is not None:
        return "mapped-csv"
    kinds = set()
    for path in inputs:
        if path.is_dir():
            from .image_sequence import image_sequence_folders

            if image_sequence_folders(path):  # frames, or folders of frames
                kinds.add("images")
            else:
                raise InputError(
                    "cannot tell the format of a folder (no PNG/JPG frames in it or in its "
                    "subfolders); pass `format='accel-tree'`, `format='images'`, or "
                    "`mapping='FILE.yaml'`",
                    path=path,
                )
        elif path.suffix.lower() == ".aedat4":
            kinds.add("aedat4")
        elif path.suffix.lower() == ".npy":
            kinds.add("events-npy")
        elif path.suffix.lower() == ".csv":
            kinds.add("events-csv")
        else:
            raise InputError(
                f"unknown format (suffix {path.suffix or 'none'!r}); supported: .aedat4, "
                ".npy, .csv events, folders with `format` or `mapping`",
                path=path,
            )
    if len(kinds) != 1:
        raise InputError(
            f"inputs mix formats ({', '.join(sorted(kinds))}); ingest each format separately"
        )
    return kinds.pop()


def ingest(
    inputs: Sequence[str | Path],
    out: str | Path,
    *,
    options: IngestOptions | None = None,
    overwrite: bool = False,
    compression: Compression = DEFAULT_COMPRESSION,
    progress: Progress | None = None,
    command: str | None = None,
    on_note: Callable[[str], None] | None = None,
) -> Path:
    """Ingest raw recordings into one validated tactile HDF5 file; returns its path.

    Nothing is written unless the whole ingest succeeds: on any error the temporary
    file is removed and an existing ``out`` is left as it was. on_note: called, once the
    file is written, with each one-line note about an assumption the readers made and the
    file records (image folders without timestamps: the frame rate assumed).
    """
    options = options or IngestOptions()
    progress = progress or NullProgress()
    paths = [Path(p) for p in inputs]
    if not paths:
        raise InputError("no input files given")
    for path in paths:
        if not path.exists():
            raise missing_file_error(path)
    fmt = detect_format(paths, options)
    # the sidecars are small: check them before the (possibly long) ingest of the data
    from .sidecars import apply_sidecars, read_annotations, read_trial_labels

    annotations = None if options.annotations is None else read_annotations(options.annotations)
    trial_labels = (None if options.trial_labels is None
                    else read_trial_labels(options.trial_labels))
    config = {
        "format": fmt,
        **options.as_config(),
        "compression_level": compression.level,
        "inputs": [str(p) for p in paths],
    }
    with StoreWriter(
        out, command=command, config=config, overwrite=overwrite, compression=compression
    ) as writer:
        module_name, func_name = FORMATS[fmt].split(":")
        reader = getattr(importlib.import_module(module_name), func_name)
        notes = reader(paths, writer, options, progress) or []  # a reader may return notes
        if not writer.trial_names:
            raise InputError("no trials found in the inputs", path=paths[0])
        if options.labels:
            for name in writer.trial_names:
                writer.trial_writer(name).set_labels(**options.labels)
        apply_sidecars(writer, annotations=annotations, labels=trial_labels)
        for sidecar in (options.annotations, options.trial_labels):
            if sidecar is not None:
                writer.add_source(sidecar)
        written = writer.commit()
    if on_note is not None:
        for note in notes:
            on_note(note)
    return written


def parse_labels(pairs: Sequence[str]) -> dict[str, str | int | float]:
    """``["object=box", "speed=0.02"]`` -> ``{"object": "box", "speed": 0.02}``."""
    out: dict[str, str | int | float] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"`labels` {pair!r} must look like key=value")
        out[key.strip()] = _number_or_text(value.strip())
    return out


def _number_or_text(value: str) -> str | int | float:
    for cast in (int, float):
        try:
            return cast(value)
        except ValueError:
            pass
    return value


__all__ = ["IngestOptions", "ingest", "detect_format", "parse_labels", "FORMATS"]
