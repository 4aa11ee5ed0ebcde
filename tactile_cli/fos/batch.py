"""``tactile fit-fos FILE...``: the first-order fits of many tactile files, on Dask.

:func:`fit_each` plans one task per HDF5 file and runs them through
:func:`tactile_cli.batch.run_each` (a local cluster of ``workers`` processes, an existing one
at ``scheduler``, or this process with ``workers=0``). Each task is :func:`fit_task`: it
opens its own file in its worker (tasks carry paths, never open files), fits every trial's
regions with :func:`~tactile_cli.fos.fit_file.fit_fos_file` and writes the groups into the
file through the store's atomic update (a validated copy renamed over it), so a worker
killed half-way leaves the file as it was.

Restart: a file whose fit groups already hold fits made with the same config is skipped
(``overwrite`` fits it again); groups made with another config fail that file with the
usual "exists" error unless ``overwrite``. A failed file never stops the others.

Every worker loads the compiled solvers from the persistent compilation cache
(:mod:`.compile_cache`) or compiles them once; a worker fits its files one after another.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from ..batch import FileBatchResult, FileCounts, FileItem, run_each
from ..config_file import missing_file_error
from ..errors import InputError
from ..store.provenance import current_command
from ..store.trials import TactileFile
from .fit import FitOptions
from .table import GROUP_NAMES, fit_summary


def _config_text(config: Mapping[str, Any] | None) -> str | None:
    """A config as the store records it on a group (``config_json``)."""
    return None if config is None else json.dumps(config, sort_keys=True, default=str)


def already_fitted(path: Path, regions: Sequence[str], config: Mapping[str, Any] | None) -> bool:
    """Whether every region's fit group exists in ``path`` with this ``config``; False for
    a file that cannot be read (its task then says why)."""
    wanted = _config_text(config)
    try:
        with TactileFile(path) as tf:
            for region in regions:
                if not tf.has_derived("fits", GROUP_NAMES[region]):
                    return False
                attrs = tf.derived("fits", GROUP_NAMES[region], columns=[]).attrs
                if wanted is None or attrs.get("config_json") != wanted:
                    return False
    except InputError:
        return False
    return True


def fit_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`fit_each` (module level, so Dask workers import it): spec
    ``{"input", "regions", "region_source", "bin_s", "press_duration_s", "order",
    "options" (FitOptions fields), "overwrite", "config", "command", "records"}``. Fits
    and writes the file; returns ``{"written", "bin_s", "summary" (per region), "records"
    (per region, when asked), "notes"}``."""
    from .compile_cache import enable_compilation_cache
    from .fit_file import fit_fos_file
    from .table import fit_records

    enable_compilation_cache()
    options = FitOptions(**spec["options"])
    result = fit_fos_file(
        spec["input"], regions=spec["regions"], region_source=spec["region_source"],
        bin_s=spec["bin_s"], press_duration_s=spec["press_duration_s"], order=spec["order"],
        options=options, write=True, overwrite=spec["overwrite"], config=spec["config"],
        command=spec["command"])
    records = {r: fit_records(result.fits[r], result.labels) for r in spec["regions"]}
    notes = []
    for region, recs in records.items():
        failed = Counter(r["status"] for r in recs if r["status"] != "converged")
        for status, n in sorted(failed.items()):
            message = next(r["status_message"] for r in recs if r["status"] == status)
            notes.append(f"{region}: {status} ({n} trial(s)): {message}")
    out: dict[str, Any] = {"written": result.written, "bin_s": result.bin_s,
                           "summary": {r: fit_summary(recs) for r, recs in records.items()},
                           "notes": notes}
    if spec["records"]:
        out["records"] = records
    return out


def fit_each(
    paths: Sequence[str | Path],
    *,
    regions: Sequence[str] = ("press", "slip"),
    region_source: str = "auto",
    bin_s: float | None = None,
    press_duration_s: float | None = None,
    order: bool = True,
    options: FitOptions | None = None,
    overwrite: bool = False,
    config: Mapping[str, Any] | None = None,
    records: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    command: str | None = None,
    on_plan: Callable[[list[FileItem]], None] | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FileBatchResult:
    """Fit the ``regions`` of every trial of each file and write them into it (see the
    module docstring); never raises for a failed file: its item says ``failed``.

    The fit arguments are those of :func:`~tactile_cli.fos.fit_file.fit_fos_file`;
    ``records``: return every trial's row in each item's value (else per-region summaries
    only). ``scheduler``, ``workers``: where the tasks run
    (:func:`tactile_cli.batch.map_tasks`). ``on_plan`` gets the items once planned,
    ``on_progress`` the counts, ``on_item`` each item as its task finishes.
    """
    files = [Path(p) for p in paths]
    if not files:
        raise InputError("no input files given")
    for path in files:
        if not path.exists():
            raise missing_file_error(path)
    seen: dict[Path, Path] = {}
    for path in files:
        key = path.resolve()
        if key in seen:
            raise InputError(f"given twice (as {str(seen[key])!r} and {str(path)!r}); two "
                             "tasks would write into one file", path=path)
        seen[key] = path
    items = []
    for path in files:
        done = not overwrite and already_fitted(path, regions, config)
        items.append(FileItem(str(path), str(path), "skipped" if done else "todo"))
    if on_plan is not None:
        on_plan(items)
    base = {"regions": list(regions), "region_source": region_source, "bin_s": bin_s,
            "press_duration_s": press_duration_s, "order": order,
            "options": asdict(options or FitOptions()), "overwrite": overwrite,
            "config": None if config is None else dict(config),
            "command": command if command is not None else current_command(),
            "records": records}
    return run_each(fit_task, items, lambda item: {**base, "input": item.input},
                    verb="fit-fos", scheduler=scheduler, workers=workers,
                    on_progress=on_progress, on_item=on_item)


__all__ = ["already_fitted", "fit_each", "fit_task"]
