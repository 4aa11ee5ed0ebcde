"""What every batch command shares: the ``--scheduler``/``--workers`` options and the
printing of a file-to-file batch (a line per finished input, a progress bar on a terminal,
a summary line or ``--json``, exit 2 when an input failed after the others are done)."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ._errors import EXIT_BAD_INPUT
from ._output import Progress

if TYPE_CHECKING:
    from ..batch import FileBatchResult, FileCounts, FileItem


def _lead(what: str, text: str) -> str:
    return f"{what}{text}" if what else text[0].upper() + text[1:]


def scheduler_option(what: str = "") -> Any:
    """``--scheduler ADDRESS``; ``what`` prefixes the help (``--out-dir: ``)."""
    return Annotated[str | None, typer.Option(
        "--scheduler", help=_lead(what, "address of an existing Dask scheduler "
                                  "(tcp://host:8786) to send the tasks to; default: "
                                  "$TACTILE_DASK_SCHEDULER, else a local cluster."),
        metavar="ADDRESS", show_default=False)]


def workers_option(what: str = "", unit: str = "input") -> Any:
    """``--workers N``: processes of the local cluster."""
    return Annotated[int | None, typer.Option(
        "--workers", min=0, help=_lead(what, "worker processes of the local Dask cluster "
                                       f"(default: the cores; 0: one {unit} after another "
                                       "in this process)."),
        show_default=False)]


#: The two options as most batch commands show them.
SchedulerOption = scheduler_option()
WorkersOption = workers_option()
#: Library argument names -> flags, for ``to_flags`` of the batch options.
BATCH_FLAGS = {"scheduler": "--scheduler", "workers": "--workers"}


class FileBatchPrinter:
    """Progress and per-input lines of a :func:`tactile_cli.batch.run_each` batch on stderr.

    ``describe(item)`` gives the text after ``INPUT: ok`` for a finished input (for
    example ``-> out.h5`` or a fit summary); ``flags`` turns library argument names in
    errors and notes into the command's flags; ``todo`` words the plan line's count of
    inputs to do (``to ingest``)."""

    def __init__(self, verb: str, *, progress: bool | None = None,
                 describe: Callable[[FileItem], str] | None = None,
                 flags: Callable[[str], str] = lambda s: s, todo: str = "to do"):
        self.verb, self.describe, self.flags, self.todo = verb, describe, flags, todo
        self.progress = Progress(verb, "inputs", show=progress)
        self.say = self.progress.say

    def on_plan(self, items: list[FileItem]) -> None:
        todo = sum(item.status == "todo" for item in items)
        self.say(f"{self.verb}: {len(items)} inputs: {todo} {self.todo}, {len(items) - todo} up "
                 "to date (skipped)")

    def on_progress(self, c: FileCounts) -> None:
        self.progress.update(total=c.total, completed=c.done + c.failed,
                             description=f"{self.verb}: {c.done}/{c.total} done, {c.running} "
                             f"running, {c.failed} failed")

    def on_item(self, item: FileItem) -> None:
        if item.status == "ok":
            tail = self.describe(item) if self.describe else f"-> {item.output}"
            self.say(f"{item.input}: ok {tail}".rstrip())
            for note in item.notes:
                self.say(f"tactile: note: {item.input}: {self.flags(note)}")
        else:
            error = item.error or ""
            if error.startswith(f"{item.input}: "):  # the error names the input first
                error = error[len(item.input) + 2:]
            self.say(f"{item.input}: failed: {self.flags(error)}")

    @contextmanager
    def running(self) -> Iterator[FileBatchPrinter]:
        with self.progress.running():
            yield self


def finish_batch(result: FileBatchResult, *, as_json: bool,
                 payload: dict[str, Any] | None = None) -> None:
    """Print the summary line (or the JSON of every item, with ``payload`` merged in) and
    exit 2 when an input failed."""
    if as_json:
        typer.echo(json.dumps({**result.as_dict(), **(payload or {})}, indent=2, default=str))
    else:
        typer.echo(result.summary())
    if not result.ok:
        raise typer.Exit(code=EXIT_BAD_INPUT)


def run_file_batch(verb: str, run: Callable[..., FileBatchResult], *,
                   progress: bool | None, as_json: bool, flags: dict[str, Any],
                   describe: Callable[[FileItem], str] | None = None,
                   todo: str = "to do") -> None:
    """``run(on_plan=, on_progress=, on_item=)`` (a library batch verb with its arguments
    bound) with a :class:`FileBatchPrinter`, then :func:`finish_batch`; ``flags``: the
    command's table for :func:`to_flags`."""
    from ._errors import spell

    printer = FileBatchPrinter(verb, progress=progress, todo=todo, describe=describe,
                               flags=lambda t: spell(t, flags))
    with printer.running():
        result = run(on_plan=printer.on_plan, on_progress=printer.on_progress,
                     on_item=printer.on_item)
    finish_batch(result, as_json=as_json)


__all__ = ["BATCH_FLAGS", "FileBatchPrinter", "SchedulerOption", "WorkersOption",
           "finish_batch", "run_file_batch", "scheduler_option", "workers_option"]
