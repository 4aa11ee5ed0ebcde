"""`tactile samples DIR`"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Annotated

import typer

from ._errors import run_guarded


def samples_command(
    out: Annotated[Path, typer.Argument(
        help="Folder to write the sample recordings into.", metavar="FOLDER", show_default=False)],
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same files).")] = 0,
    n_events: Annotated[int, typer.Option(min=1, help="Events per event recording.")] = 200_000,
) -> None:
    """Write small synthetic recordings of every input format `tactile ingest` reads but
    AEDAT4 (a binary container this toolkit only reads), and print the command that
    ingests each."""

    def body() -> None:
        from ..samples import write_all

        result = write_all(out, seed=seed, n_events=n_events)
        for name, args in result["commands"].items():
            typer.echo(f"{name}: tactile {shlex.join(args)} --out {name}.h5")

    run_guarded(body, flags={"n_events": "--n-events", "seed": "--seed"})
