"""Printing results: the JSON of a result's ``as_dict()``, or the table and lines it gives
of itself (``table()``: title, columns, rows of text; ``summary_lines()``)."""

from __future__ import annotations

import json
from typing import Any

import typer


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


__all__ = ["print_result", "print_table"]
