"""`tactile validate FILE...`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..store.validate import validate_file
from ._errors import EXIT_BAD_INPUT


def validate_command(
    files: Annotated[list[Path], typer.Argument(help="HDF5 files to check.", metavar="FILE",
                                                show_default=False)],
    as_json: Annotated[bool, typer.Option("--json", help="Print the reports as JSON.")] = False,
) -> None:
    """Check files against the tactile schema. Exit 0 when all are valid, 1 when any is not,
    2 when a file cannot be opened at all (missing, not HDF5, damaged beyond reading)."""
    reports = [validate_file(f) for f in files]
    unreadable = [r for r in reports if not r.readable]
    if as_json:
        typer.echo(json.dumps([r.as_dict() for r in reports], indent=2))
    else:
        for r in reports:
            if not r.readable:
                continue
            if r.ok:
                typer.echo(f"{r.file}: valid (schema {r.schema_version})")
            else:
                typer.echo(f"{r.file}: {len(r.violations)} violation(s)")
                for v in r.violations:
                    typer.echo(f"  {v}")
            for note in r.notes:
                typer.echo(f"  note: {note}")
    for r in unreadable:  # one line each, as every other command's input errors
        why = "; ".join(v.message for v in r.violations)
        typer.echo(f"tactile: error: {r.file}: {why}", err=True)
    if unreadable:
        raise typer.Exit(EXIT_BAD_INPUT)
    raise typer.Exit(0 if all(r.ok for r in reports) else 1)
