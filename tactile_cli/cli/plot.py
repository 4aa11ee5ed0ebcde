"""`tactile plot FILE... --out DIR`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {}


def plot_command(
    files: Annotated[list[Path], typer.Argument(help="Tactile HDF5 files.", metavar="FILE",
                                                show_default=False)],
    out: Annotated[Path, typer.Option(
        "--out", "-o", help="Folder for the PNGs and index.html.", metavar="FOLDER",
        show_default=False)],
    max_trials: Annotated[int, typer.Option(min=1, help="Trials drawn per file.")] = 4,
) -> None:
    """Quick-look figures of each file (events per 20 ms, signals with labels, frames) and
    one self-contained HTML page that shows them with the files' summaries."""

    def body() -> None:
        from ..plots.quicklook import write_quicklook  # matplotlib loads only when plotting

        typer.echo(f"wrote {write_quicklook(files, out, max_trials=max_trials)}")

    run_guarded(body, flags=FLAGS)
