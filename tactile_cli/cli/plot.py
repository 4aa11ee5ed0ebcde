"""`tactile plot FILE... --out DIR`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import run_guarded


def plot_command(
    files: Annotated[list[Path], typer.Argument(help="Tactile HDF5 files.", metavar="FILE",
                                                show_default=False)],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Folder for the PNGs and index.html.", metavar="FOLDER",
                     show_default=False),
    ],
    max_trials: Annotated[int, typer.Option(min=1, help="Trials drawn per file.")] = 4,
) -> None:
    """Quick-look figures of each file (events per 20 ms, signals with labels, frames) and
    one self-contained HTML page that shows them with the files' summaries."""

    def body() -> None:
        from ..plots.quicklook import write_html  # matplotlib loads only when plotting
        from ..store.outdir import check_output_folder, output_folder
        from ..store.trials import TactileFile

        # figures are added to an existing --out (same names replaced); a file there is not
        check_output_folder(out, merge=True)
        for f in files:  # every input opens (schema gate included) before any work
            with TactileFile(f):
                pass
        with output_folder(out, merge=True) as tmp:  # in place only when every figure is
            write_html(list(files), tmp, max_trials=max_trials)
        typer.echo(f"wrote {out / 'index.html'}")

    run_guarded(body)
