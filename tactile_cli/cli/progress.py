"""Rich progress on stderr implementing :class:`tactile_cli.progress.Progress`: a bar
(:class:`RichProgress`) and a spinner for one long step (:class:`Spinner`)."""

from __future__ import annotations

import sys
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)


class RichProgress:
    """Progress bar on stderr; silent when stderr is not a terminal unless forced."""

    def __init__(self, *, enabled: bool | None = None):
        enabled = sys.stderr.isatty() if enabled is None else enabled
        self._bar = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.percentage:>3.0f}%"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=Console(stderr=True),
            disable=not enabled,
            transient=False,
        )
        self._task: TaskID | None = None

    def __enter__(self) -> RichProgress:
        self._bar.start()
        return self

    def __exit__(self, *exc) -> None:
        self._bar.stop()

    def start(self, total: float, description: str) -> None:
        self._task = self._bar.add_task(description, total=total)

    def advance(self, amount: float = 1) -> None:
        if self._task is not None:
            self._bar.advance(self._task, amount)

    def finish(self) -> None:
        if self._task is not None:
            task = self._bar.tasks[self._task]
            self._bar.update(self._task, completed=task.total)
            self._task = None


class Spinner:
    """A spinner on stderr from ``start`` to ``finish`` (only when stderr is a terminal):
    for one long step whose progress cannot be counted (a compiled fit)."""

    def __init__(self) -> None:
        self._status: Any = None

    def start(self, total: float, description: str) -> None:  # noqa: ARG002
        if sys.stderr.isatty() and self._status is None:
            self._status = Console(stderr=True).status(description)
            self._status.__enter__()

    def advance(self, amount: float = 1) -> None:
        pass

    def finish(self) -> None:
        if self._status is not None:
            self._status.__exit__(None, None, None)
            self._status = None


#: The ``--progress/--no-progress`` option every long-running command takes.
ProgressOption = Annotated[
    bool | None,
    typer.Option("--progress/--no-progress",
                 help="Show a progress bar (default: when stderr is a terminal).",
                 show_default=False),
]
