"""The `tactile` command: a thin Typer layer over the library.

Each command lives in its own module under ``tactile_cli/cli/`` and only parses options,
calls one library function and prints. Commands are registered here.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer
from typer import rich_utils
from typer.core import TyperGroup

from .._version import __version__
from . import accel_prepare as _accel_prepare
from . import accumulate as _accumulate
from . import centroids as _centroids
from . import compare as _compare
from . import detect_contact as _detect_contact
from . import detect_delay as _detect_delay
from . import evaluate as _evaluate
from . import export as _export
from . import features as _features
from . import fit_fos as _fit_fos
from . import frames as _frames
from . import grade as _grade
from . import heightmap as _heightmap
from . import info as _info
from . import ingest as _ingest
from . import monitor as _monitor
from . import normal_labels as _normal_labels
from . import perturb as _perturb
from . import plot as _plot
from . import report as _report
from . import samples as _samples
from . import simulate as _simulate
from . import simulate_avoidance as _simulate_avoidance
from . import simulate_digit_press as _simulate_digit_press
from . import slip_interface as _slip_interface
from . import slip_rate as _slip_rate
from . import slip_signal as _slip_signal
from . import sweep as _sweep
from . import synth as _synth
from . import train as _train
from . import validate as _validate
from . import vibro_model as _vibro_model
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
app.command("accumulate", help="Event counts per 20 ms bin, moving average and action regions.")(
    _accumulate.accumulate_command
)
app.command("samples", help="Write small synthetic recordings of every input format but AEDAT4.")(
    _samples.samples_command
)
app.command("fit-fos", help="Fit FOS models (eqs. 16-17) to the press and slip regions.")(
    _fit_fos.fit_fos_command
)
app.command("synth", help="Model-based training trajectories of event counts (FOS, sec. 5.1).")(
    _synth.synth_command
)
app.command("validate", help="Check HDF5 files against the tactile schema; list every violation.")(
    _validate.validate_command
)

app.command("frames", help="Event frames (PNG) and a contact sheet with ROIs, like Fig. 13.")(
    _frames.frames_command
)
app.command("centroids", help="ROI centroid trajectories (eq. 19) as a stream for train/evaluate.")(
    _centroids.centroids_command
)
app.command("slip-rate", help="Slip speed and displacement from ROI event centroids (m/s, m).")(
    _slip_rate.slip_rate_command
)

app.command("grade", help="Grade the pressing force of every trial (fuzzy, Table III).")(
    _grade.grade_command
)
app.add_typer(_simulate.app, name="simulate")
_simulate.app.command("digit-press")(_simulate_digit_press.digit_press_command)
_simulate.app.command("digit-avoidance")(_simulate_avoidance.digit_avoidance_command)
app.add_typer(_features.app, name="features")
app.command("slip-interface", help="Object/hand or object/world slip from taxel arrays: "
            "naive Bayes on power ratio and group coherence, nested CV (paper 004).")(
    _slip_interface.slip_interface_command
)

_MANY_FILES = {"allow_extra_args": True}  # `--data a.h5 b.h5` (a shell glob after --data)
app.command("train", context_settings=_MANY_FILES,
            help="Train an LSTM, CNN, FNN or MLP on windows of HDF5 recordings (run folder).")(
    _train.train_command
)
app.command("evaluate", context_settings=_MANY_FILES,
            help="Accuracy, per-class P/R/F1, confusion matrix and latency of a trained run.")(
    _evaluate.evaluate_command
)

app.command("export", help="A trained run as one ONNX or TorchScript file with its "
            "preprocessing inside, and a JSON sidecar.")(_export.export_command)
app.command("compare", help="Accuracy against latency of several runs, Pareto front and the "
            "model the scene needs.")(_compare.compare_command)
app.command("perturb", context_settings=_MANY_FILES,
            help="Accuracy of runs on perturbed copies of the data, with breaking points.")(
    _perturb.perturb_command
)
app.command("accel-prepare", help="Accelerometer recordings as segments with a speed target "
            "and an optional bandwidth limit (paper 001).")(_accel_prepare.accel_prepare_command)
app.command("detect-delay", context_settings=_MANY_FILES,
            help="Samples and inference time a run needs to detect slippage (paper 001).")(
    _detect_delay.detect_delay_command
)
app.command("vibro-model", help="Resonances of the lumped finger-gripper-object model "
            "without and with contact (paper 003).")(_vibro_model.vibro_model_command)
app.command("detect-contact", help="Contact and touch detection from active vibration and "
            "force, offline or on a live stream (paper 003).")(
    _detect_contact.detect_contact_command
)
app.command("sweep", help="Train and evaluate a grid of model x window x channel set on "
            "Dask: one table, Fig. 8 and the speed-accuracy chart.")(_sweep.sweep_command)
app.command("report", context_settings=_MANY_FILES,
            help="One self-contained HTML page of runs, comparison and data files.")(
    _report.report_command
)
app.command("monitor", help="Replay visuotactile trials through the slip-avoidance monitor: "
            "modes, grip commands, slips caught (paper 002, sec. V).")(_monitor.monitor_command)
app.command("heightmap", help="Height maps of visuotactile frames: MLP normals, eq. 9 and a "
            "DST Poisson solve (paper 002, Fig. 2).")(_heightmap.heightmap_command)
app.command("slip-signal", help="Slip signal on a tactile mesh (eq. 10), adaptive threshold "
            "and slip decision per trial (paper 002).")(_slip_signal.slip_signal_command)
app.command("normal-labels", help="Calibration pixel table of the normal MLP from "
            "ball-bearing presses: contact circles, sphere normals (paper 002, eqs. 5-8).")(
    _normal_labels.normal_labels_command
)
arrange(app)


def main() -> None:
    app()
