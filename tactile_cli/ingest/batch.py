"""Many inputs, one output each: ``tactile ingest INPUT... --out-dir DIR`` on Dask.

:func:`ingest_each` plans one task per input (a file, or a recording folder, as
:func:`~tactile_cli.ingest.ingest` takes them), skips inputs whose output
``<out_dir>/<input stem>.h5`` is newer than the input (and than the mapping and sidecar
files), and runs the rest through :func:`tactile_cli.batch.map_tasks`: a local cluster of
``workers`` processes, an existing one at ``scheduler``, or this process (``workers=0``).
Each task is :func:`ingest_task`, which calls the single-output :func:`ingest` with
``[input]`` and the output path: the writer's temporary file and rename make every output
atomic, so a stopped batch started again does only what is missing. A failed input is a
failed item with its one-line error; the others go on.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..batch import (
    FileBatchResult,
    FileCounts,
    FileItem,
    newest_mtime,
    plan_outputs,
    run_each,
)
from ..errors import InputError
from ..store.provenance import current_command
from ..store.writer import DEFAULT_COMPRESSION, Compression
from . import ingest
from .contract import FormatOptions
from .registry import AUTO, FORMATS, option_names

#: One input of a batch and its output (see :class:`tactile_cli.batch.FileItem`).
IngestItem = FileItem
#: Progress counts of a batch (see :class:`tactile_cli.batch.FileCounts`).
IngestCounts = FileCounts
#: Every input's item (see :class:`tactile_cli.batch.FileBatchResult`).
IngestBatchResult = FileBatchResult


def output_name(path: Path) -> str:
    """``rec.aedat4`` -> ``rec.h5``; a folder ``press_01/`` -> ``press_01.h5``."""
    return f"{path.name if path.is_dir() else path.stem}.h5"


def _option_files(options: Mapping[str, Any] | FormatOptions | None) -> list[Path]:
    """The files the format options name (a mapping file), whatever the format."""
    if options is None:
        return []
    if isinstance(options, FormatOptions):
        return options.files()
    path_options = {k for f in FORMATS.values() for k in f.Options.path_fields()}
    return [Path(v) for k, v in options.items() if k in path_options and v is not None]


def plan(inputs: Sequence[str | Path], out_dir: str | Path, *,
         options: Mapping[str, Any] | FormatOptions | None = None,
         overwrite: bool = False) -> list[IngestItem]:
    """One item per input, ``skipped`` where its output exists and is newer than the input
    and the files the options name (a mapping), unless ``overwrite``. Refused before any
    work: a missing input, two inputs with one output name, an output that is a folder."""
    deps = max((newest_mtime(p) for p in _option_files(options) if p.exists()), default=0.0)
    return plan_outputs(inputs, out_dir, output_name=output_name, newer_than=deps,
                        overwrite=overwrite,
                        same_name_hint="rename one, or ingest them into one file with `out`")


def ingest_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`ingest_each` (module level, so Dask workers import it): spec
    ``{"input", "output", "format", "options" (the format's options: a dict of option names,
    or an options model), "labels", "compression" (level or None), "command"}``; ingests
    the input into its own output, replacing an out-of-date one. Returns
    ``{"output", "notes"}``."""
    notes: list[str] = []
    Path(spec["output"]).parent.mkdir(parents=True, exist_ok=True)
    written = ingest([spec["input"]], spec["output"], format=spec["format"],
                     options=spec["options"], labels=spec["labels"], overwrite=True,
                     compression=Compression(spec["compression"]), command=spec["command"],
                     on_note=notes.append)
    return {"output": str(written), "notes": notes}


def ingest_each(
    inputs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    format: str = AUTO,
    options: Mapping[str, Any] | FormatOptions | None = None,
    labels: Mapping[str, str | int | float] | None = None,
    annotations: str | Path | None = None,
    trial_labels: str | Path | None = None,
    overwrite: bool = False,
    compression: Compression = DEFAULT_COMPRESSION,
    scheduler: str | None = None,
    workers: int | None = None,
    command: str | None = None,
    on_plan: Callable[[list[IngestItem]], None] | None = None,
    on_progress: Callable[[IngestCounts], None] | None = None,
    on_item: Callable[[IngestItem], None] | None = None,
) -> IngestBatchResult:
    """Ingest each input into its own file ``<out_dir>/<input stem>.h5`` (see the module
    docstring); never raises for a failed input: its item says ``failed`` with the error.

    ``format``, ``options``, ``labels`` as for :func:`~tactile_cli.ingest.ingest` (the
    format is told per input when ``"auto"``); an option no format takes is refused before
    any work. ``annotations`` and ``trial_labels`` name the trials of one output file, so
    they are refused here. ``scheduler``, ``workers``: where the tasks run
    (:func:`tactile_cli.batch.map_tasks`; ``workers=0``: one after another in this
    process). ``on_plan`` gets the items once planned, ``on_progress`` the counts,
    ``on_item`` each item as its task finishes.
    """
    if annotations is not None or trial_labels is not None:
        raise InputError("`annotations` and `trial_labels` name the trials of one output "
                         "file; use them with `out`, not with `out_dir`")
    if isinstance(options, Mapping):
        known = option_names()
        unknown = [k for k in options if k not in known]
        if unknown:
            raise InputError(f"`{unknown[0]}` is not an option of any format (format options: "
                             f"{', '.join(f'`{k}`' for k in known)})")
        options = {k: str(v) if isinstance(v, Path) else v for k, v in options.items()}
    items = plan(inputs, out_dir, options=options, overwrite=overwrite)
    if on_plan is not None:
        on_plan(items)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    command = command if command is not None else current_command()
    shared = {"format": format, "options": options, "labels": dict(labels or {}),
              "compression": compression.level, "command": command}
    return run_each(ingest_task, items,
                    lambda item: {"input": item.input, "output": item.output, **shared},
                    verb="ingest", out_dir=str(out_dir), scheduler=scheduler,
                    workers=workers, on_progress=on_progress, on_item=on_item)


__all__ = ["IngestBatchResult", "IngestCounts", "IngestItem", "ingest_each", "ingest_task",
           "output_name", "plan"]
