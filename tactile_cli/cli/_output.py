"""Pieces every command shares on the way out: JSON on stdout, warnings on stderr, text
tables, and the progress of a long command (a bar on a terminal, else one line per step).

The library returns dataclasses and plain text (:mod:`tactile_cli.text_table`: results as
:class:`~tactile_cli.text_table.TextTable` rows and lines); this module only renders
them; results that render themselves (``table()``, ``summary_lines()``) go through
:func:`print_result`.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Literal

import typer

from ..text_table import TextTable


def echo_json(obj: Any) -> None:
    """``obj`` as strict, indented JSON on stdout (NaN and infinities as null)."""
    from ..learn.runs import dumps

    typer.echo(dumps(obj))


def warn(messages: Iterable[str]) -> None:
    """Each message as one ``tactile: warning:`` line on stderr."""
    for message in messages:
        print(f"tactile: warning: {message}", file=sys.stderr)


def _rich_table(table: TextTable) -> Any:
    from rich.table import Table

    out = Table(title=table.title, caption=table.caption)
    for i, col in enumerate(table.columns):
        out.add_column(col, justify="left" if table.is_text(i) else "right",
                       overflow="fold" if i in table.fold else "ellipsis")
    for row in table.rows:
        out.add_row(*row)
    return out


def print_blocks(blocks: Sequence[str | TextTable], *,
                 width: int | Literal["natural"] | None = None) -> None:
    """Print lines and tables on stdout. ``width`` (used when stdout is not a terminal):
    a number of columns, or ``"natural"``: as wide as the widest table needs, so no cell
    is cut or folded in a file or a pipe."""
    from rich.console import Console

    items = [_rich_table(b) if isinstance(b, TextTable) else b for b in blocks]
    columns: int | None = None
    if not sys.stdout.isatty():
        if width == "natural":
            wide = Console(width=10_000)
            widths = [wide.measure(i).maximum for i in items if not isinstance(i, str)]
            columns = max(widths) if widths else None
        else:
            columns = width
    console = Console(width=columns)
    for item in items:
        if isinstance(item, str):
            console.print(item, markup=False, highlight=False, soft_wrap=True)
        else:
            console.print(item)


class Progress:
    """The progress of a long command on stderr: a bar when ``show`` (default: stderr is a
    terminal), else one line per :meth:`say` or :meth:`step`; nothing at all but the bar
    when ``quiet`` (``--json``)."""

    def __init__(self, description: str, unit: str, *, show: bool | None = None,
                 quiet: bool = False, total: int | None = None):
        from rich.console import Console
        from rich.progress import BarColumn, TextColumn, TimeElapsedColumn
        from rich.progress import Progress as Bar

        console = Console(stderr=True)
        self.show = console.is_terminal if show is None else show
        self.quiet = quiet
        self.bar = Bar(TextColumn("{task.description}"), BarColumn(),
                       TextColumn(f"{{task.completed}}/{{task.total}} {unit}"),
                       TimeElapsedColumn(), console=console, disable=not self.show)
        self.task = self.bar.add_task(description, total=total)

    def say(self, line: str) -> None:
        """A line above the bar, or on its own."""
        if self.show:
            self.bar.console.print(line, markup=False, highlight=False)
        elif not self.quiet:
            print(line, file=sys.stderr, flush=True)

    def step(self, text: str, **update: Any) -> None:
        """The bar's description (and ``completed``, ``total``), or a line without a bar."""
        if self.show:
            self.bar.update(self.task, description=text, **update)
        elif not self.quiet:
            print(text, file=sys.stderr, flush=True)

    def update(self, **update: Any) -> None:
        """The bar only (``description``, ``completed``, ``total``)."""
        self.bar.update(self.task, **update)

    @contextmanager
    def running(self) -> Iterator[Progress]:
        with self.bar:
            yield self


def print_table(title: str, columns: list[str], rows: list[list[str]], *,
                width: int | None = 120) -> None:
    """A rich table on stdout, every column right-aligned (``width``: columns of the
    console, None for the terminal's)."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    for col in columns:
        table.add_column(col, justify="right")
    for row in rows:
        table.add_row(*row)
    Console(width=width).print(table)


def print_result(result: Any, *, as_json: bool, indent: int | None = 2,
                 width: int | None = 120) -> None:
    """``result.as_dict()`` as JSON, or its ``table()`` (when it has one and it is not
    None) and its ``summary_lines()``."""
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=indent))
        return
    table = result.table() if hasattr(result, "table") else None
    if table is not None:
        print_table(*table, width=width)
    for line in result.summary_lines():
        typer.echo(line)


__all__ = ["Progress", "echo_json", "print_blocks", "print_result", "print_table", "warn"]
