"""A file-to-file step over many inputs: plan, skip what is done, run the rest on Dask.

The shape every batch command shares (``tactile ingest --out-dir``, ``tactile fit-fos``
over several files, ``tactile evaluate --each``)::

    items = [FileItem(str(p), str(out / f"{p.stem}.h5")) for p in inputs]   # plan
    for item in items:
        if up_to_date(item): item.status = "skipped"                          # restart
    result = run_each(task, items, lambda item: {"input": item.input, ...},
                      verb="ingest", workers=2, on_item=print)

:func:`run_each` sends one task per ``todo`` item through :func:`map_tasks` (a local
cluster, an existing one, or this process with ``workers=0``) and fills each item's
``status`` (``ok`` or ``failed``), one-line ``error``, task ``seconds``, ``notes`` and
``value`` (what the task returned, for the command to print) as tasks finish. A failed
input never stops the others; the result says which failed. The tasks write their own
outputs atomically (temporary name, then rename), so what this layer adds to a stopped
batch started again is only the skip the caller planned.

:func:`plan_outputs` is the usual plan: one output per input in a folder, skipped when
newer than its input.

It knows no tactile data: items carry paths as strings, specs are plain dicts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from ..config_file import missing_file_error
from ..errors import InputError
from ..input_guard import check_outputs
from ._dask import BatchCounts, map_tasks

Status = Literal["todo", "skipped", "ok", "failed"]


@dataclass
class FileItem:
    """One input of a batch and where its result goes: ``output`` (a file or folder),
    ``status`` (``todo`` while planned, then ``ok``, ``skipped`` or ``failed``), ``error``
    (one line naming the input), task ``seconds``, ``notes`` (the task's warnings) and
    ``value`` (the task's JSON-ready summary)."""

    input: str
    output: str
    status: Status = "todo"
    error: str | None = None
    seconds: float | None = None
    notes: list[str] = field(default_factory=list)
    value: Any = None

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        if self.seconds is not None and math.isnan(self.seconds):
            out["seconds"] = None
        return out


@dataclass(frozen=True)
class FileCounts:
    """Progress of the inputs to do: ``done`` (ok), ``running``, ``failed`` of ``total``;
    ``skipped``: up to date before the batch started (not in ``total``)."""

    total: int
    done: int
    running: int
    failed: int
    skipped: int


@dataclass
class FileBatchResult:
    """Every input's item, in the order given; ``verb`` names the step (``ingest``,
    ``fit-fos``, ``evaluate``) in the summary line."""

    verb: str
    items: list[FileItem]
    out_dir: str | None = None

    def count(self, status: Status) -> int:
        return sum(item.status == status for item in self.items)

    @property
    def ok(self) -> bool:
        return self.count("failed") == 0

    def summary(self) -> str:
        return (f"{self.verb}: {len(self.items)} inputs: {self.count('ok')} ok, "
                f"{self.count('skipped')} skipped (up to date), {self.count('failed')} failed")

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {} if self.out_dir is None else {"out_dir": self.out_dir}
        out["counts"] = {s: self.count(s) for s in ("ok", "skipped", "failed")}
        out["items"] = [item.as_dict() for item in self.items]
        return out


def newest_mtime(path: str | Path) -> float:
    """The modification time of a file, or the newest of a folder and everything in it."""
    path = Path(path)
    newest = path.stat().st_mtime
    if path.is_dir():
        for sub in path.rglob("*"):
            newest = max(newest, sub.stat().st_mtime)
    return newest


def plan_outputs(inputs: Sequence[str | Path], out_dir: str | Path, *,
                 output_name: Callable[[Path], str] = lambda p: f"{p.stem}.h5",
                 newer_than: float = 0.0, overwrite: bool = False,
                 same_name_hint: str = "rename one",
                 is_complete: Callable[[Path], bool] | None = None) -> list[FileItem]:
    """One item per input, its output ``<out_dir>/<output_name(input)>``, ``skipped`` where
    that output exists and is newer than the input (a folder: everything in it) and than
    ``newer_than`` (a time stamp of other inputs, such as a mapping), unless ``overwrite``;
    ``is_complete(output)``, when given, must also hold for it to be skipped (a damaged
    output of an earlier batch is made again). Refused before any work
    (:class:`InputError`): no input, a missing input, ``out_dir`` a file, two inputs with
    one output name (``same_name_hint`` says what to do), an output that is a folder, an
    output that is an input or contains one (:func:`~tactile_cli.input_guard.check_outputs`)."""
    paths = [Path(p) for p in inputs]
    if not paths:
        raise InputError("no input files given")
    for path in paths:
        if not path.exists():
            raise missing_file_error(path)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("`out_dir` is a file, not a folder", path=out)
    seen: dict[str, Path] = {}
    items = []
    for path in paths:
        name = output_name(path)
        if name in seen:
            raise InputError(f"inputs {str(seen[name])!r} and {str(path)!r} would both be "
                             f"written to {name!r} in `out_dir`; {same_name_hint}")
        seen[name] = path
        target = out / name
        if target.is_dir():
            raise InputError("output is a folder; remove or rename it", path=target)
        fresh = (not overwrite and target.is_file()
                 and target.stat().st_mtime > max(newest_mtime(path), newer_than)
                 and (is_complete is None or is_complete(target)))
        items.append(FileItem(str(path), str(target), "skipped" if fresh else "todo"))
    check_outputs([item.output for item in items], paths)
    return items


def run_each(
    task: Callable[[dict[str, Any]], dict[str, Any]],
    items: Sequence[FileItem],
    spec_of: Callable[[FileItem], dict[str, Any]],
    *,
    verb: str,
    out_dir: str | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FileBatchResult:
    """Run ``task(spec_of(item))`` for every ``todo`` item on Dask (see the module
    docstring) and return every item, filled in. ``task`` is a module-level function
    returning a dict; its ``notes`` key (a list of str), if present, becomes the item's
    notes and the whole dict its ``value``. A task's error is prefixed with the input's
    path unless it names the input already. Never raises for a failed input."""
    todo = [item for item in items if item.status == "todo"]
    skipped = len(items) - len(todo)

    def progress(c: BatchCounts) -> None:
        if on_progress is not None:
            on_progress(FileCounts(c.total, c.done, c.running, c.failed, skipped))

    if not todo and on_progress is not None:
        on_progress(FileCounts(0, 0, 0, 0, skipped))
    specs = [spec_of(item) for item in todo]
    keys = [f"{i}-{Path(item.input).name}" for i, item in enumerate(todo)]
    for res in map_tasks(task, specs, keys=keys, scheduler=scheduler, workers=workers,
                         on_progress=progress):
        item = todo[res.index]
        item.seconds = res.seconds
        if res.ok:
            item.status = "ok"
            item.value = res.value
            item.notes = list((res.value or {}).get("notes", []))
        else:
            error = res.error or "failed"
            item.status = "failed"
            item.error = error if Path(item.input).name in error else f"{item.input}: {error}"
        if on_item is not None:
            on_item(item)
    return FileBatchResult(verb, list(items), out_dir)


__all__ = ["FileBatchResult", "FileCounts", "FileItem", "newest_mtime", "plan_outputs",
           "run_each"]
