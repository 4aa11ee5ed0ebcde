"""`tactile ingest`: raw recordings of any supported format into one tactile HDF5 file.

Each format is one module with one :class:`~tactile_cli.ingest.contract.IngestFormat`
(``sniff``, ``describe``, ``read``) and its typed options model, registered by one line in
:data:`~tactile_cli.ingest.registry.FORMATS`. :func:`ingest` picks the format (``format``,
else told from the inputs), builds its options, opens the writer (temporary file,
validation, atomic rename), lets the format's ``read`` add sensors and trials, then adds
the options every format shares (:class:`~tactile_cli.ingest.contract.CommonOptions`):
run-wide labels and the ground-truth sidecars (``annotations``, ``trial_labels``; see
:mod:`tactile_cli.ingest.sidecars`). :func:`describe_recording` is the read-only look at a
raw recording that ``tactile info`` prints.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..config_file import missing_file_error
from ..errors import InputError
from ..input_guard import check_outputs
from ..progress import NullProgress, Progress
from ..store.writer import DEFAULT_COMPRESSION, Compression, StoreWriter
from .contract import (
    CommonOptions,
    FormatOptions,
    IngestFormat,
    RecordingSummary,
    StreamSummary,
    TrialSummary,
)
from .registry import AUTO, FORMATS, detect_format, format_options, get_format


def ingest(
    inputs: Sequence[str | Path],
    out: str | Path,
    *,
    format: str = AUTO,
    options: Mapping[str, Any] | FormatOptions | None = None,
    labels: Mapping[str, str | int | float] | None = None,
    annotations: str | Path | None = None,
    trial_labels: str | Path | None = None,
    overwrite: bool = False,
    compression: Compression = DEFAULT_COMPRESSION,
    progress: Progress | None = None,
    command: str | None = None,
    on_note: Callable[[str], None] | None = None,
) -> Path:
    """Ingest raw recordings into one validated tactile HDF5 file; returns its path.

    format: a name of :data:`~tactile_cli.ingest.registry.FORMATS` (``"events-csv"``), or
    ``"auto"`` to tell it from the inputs. options: the format's options, as a mapping of
    option names (``{"width_px": 640, "height_px": 480}``) or the format's options model
    (``EventTableOptions(width_px=640, height_px=480)``); an option the format does not take
    is an InputError naming the formats that take it. labels: added to every trial;
    annotations, trial_labels: sidecar CSV files (see :mod:`tactile_cli.ingest.sidecars`).

    Nothing is written unless the whole ingest succeeds: on any error the temporary
    file is removed and an existing ``out`` is left as it was. on_note: called, once the
    file is written, with each one-line note about an assumption the readers made and the
    file records (image folders without timestamps: the frame rate assumed; stamps a
    mapping's policy dropped or spread).
    """
    common = CommonOptions(labels=dict(labels or {}), annotations=annotations,
                           trial_labels=trial_labels)
    progress = progress or NullProgress()
    paths = [Path(p) for p in inputs]
    if not paths:
        raise InputError("no input files given")
    for path in paths:
        if not path.exists():
            raise missing_file_error(path)
    # a recording is never overwritten, nor written into (its folders are trees)
    sidecars = [p for p in (annotations, trial_labels) if p is not None]
    check_outputs({"out": out}, [p for p in paths if not p.is_dir()] + sidecars,
                  trees=[p for p in paths if p.is_dir()])
    fmt = detect_format(paths, format=format, options=options)
    fmt_options = format_options(fmt, options)
    # the sidecars are small: check them before the (possibly long) ingest of the data
    from .sidecars import apply_sidecars, read_annotations, read_trial_labels

    ann = None if common.annotations is None else read_annotations(common.annotations)
    per_trial = (None if common.trial_labels is None
                 else read_trial_labels(common.trial_labels))
    config = {
        "format": fmt.name,
        "options": fmt_options.model_dump(mode="json"),
        **common.model_dump(mode="json"),
        "compression_level": compression.level,
        "inputs": [str(p) for p in paths],
    }
    with StoreWriter(
        out, command=command, config=config, overwrite=overwrite, compression=compression
    ) as writer:
        notes = fmt.read(paths, fmt_options, writer, progress)
        if not writer.trial_names:
            raise InputError("no trials found in the inputs", path=paths[0])
        if common.labels:
            for name in writer.trial_names:
                writer.trial_writer(name).set_labels(**common.labels)
        notes = [*notes, *apply_sidecars(writer, annotations=ann, labels=per_trial)]
        for sidecar in common.files():
            writer.add_source(sidecar)
        written = writer.commit()
    if on_note is not None:
        for note in notes:
            on_note(note)
    return written


def describe_recording(path: str | Path, *, format: str = AUTO,
                       options: Mapping[str, Any] | FormatOptions | None = None
                       ) -> RecordingSummary:
    """What the raw recording at ``path`` holds, read without writing anything: its
    streams (counts, rates, time spans, sizes), the trials an ingest would make and what it
    would leave out (``tactile info RAW``). ``format`` and ``options`` as for
    :func:`ingest`; a damaged recording is the one-line InputError an ingest would raise."""
    path = Path(path)
    if not path.exists():
        raise missing_file_error(path)
    fmt = detect_format([path], format=format, options=options)
    return fmt.describe(path, format_options(fmt, options))


def raw_format(path: str | Path) -> IngestFormat[Any] | None:
    """The format the raw recording at ``path`` sniffs as, or None (a tactile HDF5 file,
    or nothing tactile reads): what ``tactile info`` uses to pick its reader."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            if f.read(8) == b"\x89HDF\r\n\x1a\n":
                return None
    except OSError:
        pass
    return next((f for f in FORMATS.values() if f.sniff(path)), None)


def parse_labels(pairs: Sequence[str]) -> dict[str, str | int | float]:
    """``["object=box", "speed=0.02"]`` -> ``{"object": "box", "speed": 0.02}``."""
    out: dict[str, str | int | float] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"`labels` {pair!r} must look like key=value")
        out[key.strip()] = _number_or_text(value.strip())
    return out


def parse_options(pairs: Sequence[str], given: Mapping[str, Any] | None = None
                  ) -> dict[str, Any]:
    """Format options from ``["chunk_events=4096", ...]`` (values kept as text: the
    format's options model converts them) added to ``given`` (options set otherwise, whose
    ``None`` values count as not set); an option set twice is an InputError."""
    out = {k: v for k, v in (given or {}).items() if v is not None}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise InputError(f"`options` {pair!r} must look like key=value")
        if key in out:
            raise InputError(f"`options` sets `{key}` a second time (`{key}` is given already)")
        out[key] = value.strip()
    return out


def _number_or_text(value: str) -> str | int | float:
    for cast in (int, float):
        try:
            return cast(value)
        except ValueError:
            pass
    return value


__all__ = ["FORMATS", "CommonOptions", "FormatOptions", "IngestFormat", "RecordingSummary",
           "StreamSummary", "TrialSummary", "describe_recording", "detect_format",
           "format_options", "get_format", "ingest", "parse_labels", "parse_options",
           "raw_format"]
