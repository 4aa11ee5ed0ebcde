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

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from ..config_file import missing_file_error
from ..errors import InputError
from ..store.writer import DEFAULT_COMPRESSION, Compression, current_command
from . import IngestOptions, ingest

Status = Literal["todo", "skipped", "ok", "failed"]


@dataclass
class IngestItem:
    """One input of a batch: its ``output``, ``status`` (``todo`` while planned, then
    ``ok``, ``skipped`` or ``failed``), ``error`` (one line), task ``seconds`` and the
    notes of its ingest."""

    input: str
    output: str
    status: Status = "todo"
    error: str | None = None
    seconds: float | None = None
    notes: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class IngestCounts:
    """Progress of the inputs to ingest: ``done`` (ok), ``running``, ``failed`` of
    ``total``; ``skipped``: outputs already up to date (not in ``total``)."""

    total: int
    done: int
    running: int
    failed: int
    skipped: int


@dataclass
class IngestBatchResult:
    """Every input's item, in the order given."""

    out_dir: str
    items: list[IngestItem]

    def count(self, status: Status) -> int:
        return sum(item.status == status for item in self.items)

    @property
    def ok(self) -> bool:
        return self.count("failed") == 0

    def summary(self) -> str:
        return (f"ingest: {len(self.items)} inputs: {self.count('ok')} ok, "
                f"{self.count('skipped')} skipped (up to date), {self.count('failed')} failed")

    def as_dict(self) -> dict[str, Any]:
        return {"out_dir": self.out_dir,
                "counts": {s: self.count(s) for s in ("ok", "skipped", "failed")},
                "items": [{**asdict(item), "seconds": None if item.seconds is None
                           or item.seconds != item.seconds else item.seconds}
                          for item in self.items]}


def output_name(path: Path) -> str:
    """``rec.aedat4`` -> ``rec.h5``; a folder ``press_01/`` -> ``press_01.h5``."""
    return f"{path.name if path.is_dir() else path.stem}.h5"


def newest_mtime(path: Path) -> float:
    """The modification time of a file, or the newest of a folder and everything in it."""
    newest = path.stat().st_mtime
    if path.is_dir():
        for sub in path.rglob("*"):
            newest = max(newest, sub.stat().st_mtime)
    return newest


def plan(inputs: Sequence[str | Path], out_dir: str | Path, *,
         options: IngestOptions | None = None, overwrite: bool = False) -> list[IngestItem]:
    """One item per input, ``skipped`` where its output exists and is newer than the input
    and the option files (mapping, sidecars), unless ``overwrite``. Refused before any
    work: a missing input, two inputs with one output name, an output that is a folder."""
    options = options or IngestOptions()
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
    for path in paths:
        name = output_name(path)
        if name in seen:
            raise InputError(f"inputs {str(seen[name])!r} and {str(path)!r} would both be "
                             f"written to {name!r} in `out_dir`; rename one, or ingest them "
                             "into one file with `out`")
        seen[name] = path
    sidecars = [p for p in (options.mapping, options.annotations, options.trial_labels)
                if p is not None]
    deps = max((newest_mtime(Path(p)) for p in sidecars if Path(p).exists()), default=0.0)
    items = []
    for path in paths:
        target = out / output_name(path)
        if target.is_dir():
            raise InputError("output is a folder; remove or rename it", path=target)
        fresh = (not overwrite and target.is_file()
                 and target.stat().st_mtime > max(newest_mtime(path), deps))
        items.append(IngestItem(str(path), str(target), "skipped" if fresh else "todo"))
    return items


def ingest_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`ingest_each` (module level, so Dask workers import it): spec
    ``{"input", "output", "options" (IngestOptions fields), "compression" (level or None),
    "command"}``; ingests the input into its own output, replacing an out-of-date one.
    Returns ``{"output", "notes"}``."""
    raw = dict(spec["options"])
    for key in ("mapping", "annotations", "trial_labels"):
        if raw.get(key) is not None:
            raw[key] = Path(raw[key])
    options = IngestOptions(**raw)
    notes: list[str] = []
    Path(spec["output"]).parent.mkdir(parents=True, exist_ok=True)
    written = ingest([spec["input"]], spec["output"], options=options, overwrite=True,
                     compression=Compression(spec["compression"]), command=spec["command"],
                     on_note=notes.append)
    return {"output": str(written), "notes": notes}


def ingest_each(
    inputs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    options: IngestOptions | None = None,
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

    ``scheduler``, ``workers``: where the tasks run (:func:`tactile_cli.batch.map_tasks`;
    ``workers=0``: one after another in this process). ``on_plan`` gets the items once
    planned, ``on_progress`` the counts, ``on_item`` each item as its task finishes.
    """
    from ..batch import map_tasks

    options = options or IngestOptions()
    if options.annotations is not None or options.trial_labels is not None:
        raise InputError("`annotations` and `trial_labels` name the trials of one output "
                         "file; use them with `out`, not with `out_dir`")
    items = plan(inputs, out_dir, options=options, overwrite=overwrite)
    if on_plan is not None:
        on_plan(items)
    todo = [item for item in items if item.status == "todo"]
    skipped = len(items) - len(todo)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    base = {k: (None if v is None else str(v)) if k in ("mapping", "annotations",
                                                         "trial_labels") else v
            for k, v in asdict(options).items()}
    command = command if command is not None else current_command()
    specs = [{"input": item.input, "output": item.output, "options": base,
              "compression": compression.level, "command": command} for item in todo]

    def progress(c: Any) -> None:
        if on_progress is not None:
            on_progress(IngestCounts(c.total, c.done, c.running, c.failed, skipped))

    if not todo and on_progress is not None:
        on_progress(IngestCounts(0, 0, 0, 0, skipped))
    for res in map_tasks(ingest_task, specs, keys=[Path(i.output).stem for i in todo],
                         scheduler=scheduler, workers=workers, on_progress=progress):
        item = todo[res.index]
        item.seconds = res.seconds
        if res.ok:
            item.status, item.notes = "ok", list(res.value["notes"])
        else:
            error = res.error or "failed"
            name = Path(item.input).name
            item.status = "failed"
            item.error = error if name in error else f"{item.input}: {error}"
        if on_item is not None:
            on_item(item)
    return IngestBatchResult(str(out_dir), items)


__all__ = ["IngestBatchResult", "IngestCounts", "IngestItem", "ingest_each", "ingest_task",
           "output_name", "plan"]
