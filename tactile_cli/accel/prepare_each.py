"""``tactile accel-prepare FILE... --out-dir FOLDER``: many accel-tree files prepared on Dask.

:func:`prepare_each` plans one task per input file, written to ``<out_dir>/<input
stem>.h5``, skips outputs newer than their input (``overwrite``: none skipped), and runs
the rest through :func:`tactile_cli.batch.run_each` (a local cluster of ``workers``
processes, an existing one at ``scheduler``, or this process with ``workers=0``). Each task
is :func:`prepare_task`, which calls :func:`~tactile_cli.accel.prepare.prepare_file` in its
worker: the store's writer makes every output atomic (temporary file, then rename), so a
stopped batch started again does only what is missing. A failed file never stops the
others.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..batch import FileBatchResult, FileCounts, FileItem, plan_outputs, run_each
from ..store.provenance import current_command


def prepare_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`prepare_each` (module level, so Dask workers import it): spec
    ``{"input", "output", "segment_s", "cutoff_hz", "command"}``; returns the
    :class:`~tactile_cli.accel.prepare.PrepareResult` as a dict."""
    from .prepare import prepare_file

    result = prepare_file(spec["input"], spec["output"], segment_s=spec["segment_s"],
                          cutoff_hz=spec["cutoff_hz"], overwrite=True,
                          command=spec["command"])
    return result.as_dict()


def prepare_each(
    inputs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    segment_s: float = 2.0,
    cutoff_hz: float | None = None,
    overwrite: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    command: str | None = None,
    on_plan: Callable[[list[FileItem]], None] | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FileBatchResult:
    """Prepare each input into ``<out_dir>/<input stem>.h5`` (see the module docstring);
    never raises for a failed input. Refused before any work: a bad ``segment_s`` or
    ``cutoff_hz``, a missing input, two inputs of one stem, an output that is a folder or
    an input, a folder that cannot be written."""
    from ..input_guard import check_outputs
    from ..store.outdir import check_output_folder
    from .prepare import check_settings

    check_settings(segment_s, cutoff_hz)
    items = plan_outputs(inputs, out_dir, overwrite=overwrite)
    check_outputs([item.output for item in items], inputs)
    check_output_folder(out_dir, merge=True)
    out = Path(out_dir)
    if on_plan is not None:
        on_plan(items)
    out.mkdir(parents=True, exist_ok=True)
    command = command if command is not None else current_command()
    return run_each(prepare_task, items,
                    lambda item: {"input": item.input, "output": item.output,
                                  "segment_s": segment_s, "cutoff_hz": cutoff_hz,
                                  "command": command},
                    verb="accel-prepare", out_dir=str(out), scheduler=scheduler,
                    workers=workers, on_progress=on_progress, on_item=on_item)


__all__ = ["prepare_each", "prepare_task"]
