"""The `tactile` command: a thin Typer layer over the library.

Each command lives in its own module under ``tactile_cli/cli/`` and only parses options,
calls one library function and prints. Commands are registered here.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer
from typer import rich_utils
from typer.core import TyperGroup

from .._version import __version__
from ._errors import EXIT_INTERRUPTED
from ._options import Abort, ClickException, NoArgsIsHelpError, finite_float_options, usage_error
from ._panels import arrange

#: Columns of ``--help`` when stdout is not a terminal (a pipe, a file, a test) and neither
#: ``COLUMNS`` nor ``TERMINAL_WIDTH`` is set: rich would use 80 and cut long paths and
#: option descriptions with an ellipsis.
HELP_WIDTH = 100


def help_width() -> int | None:
    """Columns for ``--help``: None (rich asks the terminal, or reads ``COLUMNS``) when
    stdout is a terminal or ``COLUMNS`` is set; else the wider of :data:`HELP_WIDTH` and
    the terminal that stderr or stdin is attached to (``tactile ingest --help | less``)."""
    if sys.stdout.isatty() or os.environ.get("COLUMNS", "").isdigit():
        return None
    widths = [HELP_WIDTH]
    for stream in (sys.stderr, sys.stdin):
        try:
            widths.append(os.get_terminal_size(stream.fileno()).columns)
        except (AttributeError, ValueError, OSError):  # not a terminal, or no file number
            pass
    return max(widths)


@contextmanager
def _help_rendered_wide() -> Iterator[None]:
    """Typer renders help with a rich console of ``rich_utils.MAX_WIDTH`` columns (its
    ``TERMINAL_WIDTH`` setting, else the terminal's, else 80); set it for one command."""
    before = rich_utils.MAX_WIDTH
    if before is None:
        rich_utils.MAX_WIDTH = help_width()
    try:
        yield
    finally:
        rich_utils.MAX_WIDTH = before


class _TactileGroup(TyperGroup):
    """The ``tactile`` command group: help of every command at :func:`help_width`; a bad
    command line (unknown option, bad value, missing argument) is one ``tactile: error:``
    line and exit 2, like every other error (click's multi-line box is for help only)."""

    def main(self, *args: Any, **kwargs: Any) -> Any:
        kwargs["standalone_mode"] = False
        finite_float_options(self)
        with _help_rendered_wide():
            try:
                rv = super().main(*args, **kwargs)
            except NoArgsIsHelpError as exc:
                rich_utils.rich_format_error(exc)  # `tactile` alone: the help, exit 2
                sys.exit(exc.exit_code)
            except ClickException as exc:
                sys.exit(usage_error(exc))
            except Abort:
                print("tactile: error: aborted", file=sys.stderr)
                sys.exit(EXIT_INTERRUPTED)
        if isinstance(rv, int):  # click's Exit (--help, --version) returns its code
            sys.exit(rv)
        return rv


app = typer.Typer(
    cls=_TactileGroup,
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
    version: Annotated[bool, typer.Option(
        "--version", callback=_version_callback, is_eager=True, help="Print the version and exit."
    )] = False,
) -> None:
    """Tactile-sensing research from raw recordings to trained, evaluated models."""


#: Every command: name, module (``cli/<module>.py``), its function, the one-line help of
#: ``tactile --help`` and whether it takes ``--data a.h5 b.h5`` (a shell glob after --data).
COMMANDS: tuple[tuple[str, str, str, bool], ...] = (
    ("ingest", "ingest", "Raw recordings (AEDAT4/CSV/NPY events, sensor CSVs, images) into one "
     "HDF5 file.", False),
    ("info", "info", "Sensors, trials, labels and durations of a tactile HDF5 file.", False),
    ("plot", "plot", "Quick-look figures and an HTML page of tactile HDF5 files.", False),
    ("accumulate", "accumulate", "Event counts per 20 ms bin, moving average and action "
     "regions.", False),
    ("samples", "samples", "Write small synthetic recordings of every input format but "
     "AEDAT4.", False),
    ("fit-fos", "fit_fos", "Fit FOS models (eqs. 16-17) to the press and slip regions.", False),
    ("synth", "synth", "Model-based training trajectories of event counts (FOS, sec. 5.1).",
     False),
    ("validate", "validate", "Check HDF5 files against the tactile schema; list every "
     "violation.", False),
    ("frames", "frames", "Event frames (PNG) and a contact sheet with ROIs, like Fig. 13.", False),
    ("centroids", "centroids", "ROI centroid trajectories (eq. 19) as a stream for "
     "train/evaluate.", False),
    ("slip-rate", "slip_rate", "Slip speed and displacement from ROI event centroids (m/s, m).",
     False),
    ("grade", "grade", "Grade the pressing force of every trial (fuzzy, Table III).", False),
    ("slip-interface", "slip_interface", "Object/hand or object/world slip from taxel arrays: "
     "naive Bayes on power ratio and group coherence, nested CV (paper 004).", False),
    ("train", "train", "Train an LSTM, CNN, FNN or MLP on windows of HDF5 recordings (run "
     "folder).", True),
    ("evaluate", "evaluate", "Accuracy, per-class P/R/F1, confusion matrix and latency of a "
     "trained run.", True),
    ("export", "export", "A trained run as one ONNX or TorchScript file with its preprocessing "
     "inside, and a JSON sidecar.", False),
    ("compare", "compare", "Accuracy against latency of several runs, Pareto front and the "
     "model the scene needs.", False),
    ("perturb", "perturb", "Accuracy of runs on perturbed copies of the data, with breaking "
     "points.", True),
    ("accel-prepare", "accel_prepare", "Accelerometer recordings as segments with a speed "
     "target and an optional bandwidth limit (paper 001).", False),
    ("detect-delay", "detect_delay", "Samples and inference time a run needs to detect "
     "slippage (paper 001).", True),
    ("vibro-model", "vibro_model", "Resonances of the lumped finger-gripper-object model "
     "without and with contact (paper 003).", False),
    ("detect-contact", "detect_contact", "Contact and touch detection from active vibration and "
     "force, offline or on a live stream (paper 003).", False),
    ("sweep", "sweep", "Train and evaluate a grid of model x window x channel set on Dask: one "
     "table, Fig. 8 and the speed-accuracy chart.", False),
    ("seed-spread", "seed_spread", "One config trained and evaluated at several seeds: each "
     "seed's held-out figures, their mean, SD and spread.", True),
    ("report", "report", "One self-contained HTML page of runs, comparison and data files.",
     True),
    ("monitor", "monitor", "Replay visuotactile trials through the slip-avoidance monitor: "
     "modes, grip commands, slips caught (paper 002, sec. V).", False),
    ("heightmap", "heightmap", "Height maps of visuotactile frames: MLP normals, eq. 9 and a "
     "DST Poisson solve (paper 002, Fig. 2).", False),
    ("slip-signal", "slip_signal", "Slip signal on a tactile mesh (eq. 10), adaptive threshold "
     "and slip decision per trial (paper 002).", False),
    ("slip-imprint", "slip_imprint", "Whether the grasp's contact imprint survived the lift: "
     "slip per trial, threshold learned by leave-one-object-out CV.", False),
    ("normal-labels", "normal_labels", "Calibration pixel table of the normal MLP from "
     "ball-bearing presses: contact circles, sphere normals (paper 002, eqs. 5-8).", False),
)
#: Groups of subcommands: name, module (with its ``app``).
GROUPS = (("simulate", "simulate"), ("features", "features"))


def _module(name: str) -> Any:
    return importlib.import_module(f".{name}", __package__)


for _name, _module_name, _help, _many_files in COMMANDS:
    app.command(_name, help=_help,
                context_settings={"allow_extra_args": True} if _many_files else None)(
        getattr(_module(_module_name), f"{_module_name}_command"))
for _name, _module_name in GROUPS:
    app.add_typer(_module(_module_name).app, name=_name)
_simulate = _module("simulate")
_simulate.app.command("digit-press")(_module("simulate_digit_press").digit_press_command)
_simulate.app.command("digit-avoidance")(_module("simulate_avoidance").digit_avoidance_command)
arrange(app)


def main() -> None:
    app()
