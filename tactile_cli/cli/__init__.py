"""The `tactile` command: a thin Typer layer over the library.

Each command lives in its own module under ``tactile_cli/cli/`` and only parses options,
calls one library function and prints. Commands are registered here.
"""

from __future__ import annotations

from typing import Annotated

import typer

from .._version import __version__
from . import info as _info
from . import ingest as _ingest
from . import plot as _plot
from . import samples as _samples
from . import validate as _validate

app = typer.Typer(
    name="tactile",
    help="Tactile-sensing research from raw recordings to trained, evaluated models.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"tactile {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_version_callback,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = False,
) -> None:
    """Tactile-sensing research from raw recordings to trained, evaluated models."""


app.command(
    "ingest", help="Raw recordings (AEDAT4/CSV/NPY events, sensor CSVs, images) into one HDF5 file."
)(_ingest.ingest_command)
app.command("info", help="Sensors, trials, labels and durations of a tactile HDF5 file.")(
    _info.info_command
)
app.command("plot", help="Quick-look figures and an HTML page of tactile HDF5 files.")(
    _plot.plot_command
)
app.command("samples", help="Write small synthetic recordings of every input format.")(
    _samples.samples_command
)
app.command("validate", help="Check HDF5 files against the tactile schema; list every violation.")(
    _validate.validate_command
)


def main() -> None:
    app()
