"""`tactile fit-fos FILE...`: options in, :func:`tactile_cli.fos.fit_files` called, its
result printed as a table per region, as JSON, or (several files) as a batch."""

from __future__ import annotations

import enum
import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ..fos.compile_cache import cache_root
from ..fos.fit_files import CURVE_MODELS, KINDS, REGION_SOURCES
from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption
from ._errors import Flag, run_guarded, seconds_as_ms, spell
from ._options import JsonOption
from ._output import print_blocks
from .progress import Spinner

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "bin_s": ("--bin-ms", seconds_as_ms),
    "csv": "--csv",
    "press_duration_s": "--press-duration", "write": "--no-write", **BATCH_FLAGS,
}

Kind = enum.StrEnum("Kind", {k: k for k in KINDS})
Regions = enum.StrEnum("Regions", {k: k for k in REGION_SOURCES})
CurveModel = enum.StrEnum("CurveModel", {k: k for k in CURVE_MODELS})
Solver = enum.StrEnum("Solver", {k: k for k in ("levenberg_marquardt", "gauss_newton")})
Reduce = enum.StrEnum("Reduce", {k: k for k in ("none", "mean")})

def fit_fos_command(
    files: Annotated[list[Path], typer.Argument(
        help="A tactile HDF5 file, or CSV curves fitted together: files or folders of them, each "
        "a header, then t in s and one or more response columns (t,x1,x2,...).",
        show_default=False, metavar="FILE")],
    kind: Annotated[Kind | None, typer.Option(
        help="Regions to fit (HDF5): press, slip or both; default both.",
        show_default=False)] = None,
    regions: Annotated[Regions | None, typer.Option(
        help="Where the regions come from (HDF5): the trials' annotations, detected in the "
        "counts (with --stream: steps found in the signal), or auto (annotations where present; "
        "the default; with --stream the default is annotations).", show_default=False)] = None,
    bin_ms: Annotated[float | None, typer.Option(
        min=0.001, help="Bin width in ms (HDF5); default 20 for events, a count stream's "
                        "own width.", show_default=False)] = None,
    model: Annotated[CurveModel | None, typer.Option(
        help="Model for CSV curves and --stream: pulse (eq. 16), step or ramp (eq. 17); "
             "--stream defaults to step.", show_default=False)] = None,
    units: Annotated[str | None, typer.Option(
        help="Unit of the CSV curves' response (and so of alpha); default: the unit in the "
        "response column's header, as in 'force (N)', else 'units'.", show_default=False)] = None,
    press_duration: Annotated[float | None, typer.Option(
        min=1e-6, help="Known press length T in s for the pulse (default: fitted).",
        show_default=False)] = None,
    solver: Annotated[Solver, typer.Option(
        help="Least-squares solver. Traced and compiled on first use and kept for later runs "
             f"in {cache_root()} (set $TACTILE_CACHE_DIR to move it).")
    ] = Solver.levenberg_marquardt,
    max_steps: Annotated[int, typer.Option(min=1, help="Solver step limit per fit.")] = 64,
    rtol: Annotated[float | None, typer.Option(
        help="Relative stopping tolerance of the solver, in (0, 1); default 1e-10 (fits "
             "reach the least-squares minimum to about 1e-9). A run-time input: no "
             "recompilation.", show_default=False)] = None,
    atol: Annotated[float | None, typer.Option(
        help="Absolute stopping tolerance of the solver (log tau and RMS-scaled residuals), "
             "in (0, 1); default 1e-10.", show_default=False)] = None,
    p0: Annotated[str | None, typer.Option(
        "--p0", help="Starting values of the first-order fits, e.g. 'tau=0.05,T=0.3' "
                     "(seconds; alpha=... is accepted but the gains are solved in closed "
                     "form); default: from the data.", show_default=False)] = None,
    order: Annotated[bool, typer.Option(
        "--order/--no-order",
        help="Also fit the second-order alternative and give the BIC verdict.")] = True,
    as_json: JsonOption = False,
    csv_out: Annotated[Path | None, typer.Option(
        "--csv", help="Also write the table to this CSV file.", show_default=False,
        metavar="FILE")] = None,
    plot: Annotated[Path | None, typer.Option(
        help="Folder for PNG figures of data and fitted curves (like the paper's Figs. "
             "11-12); a CSV curve's figure is named after its file.",
        show_default=False, metavar="FOLDER")] = None,
    overwrite: Annotated[bool, typer.Option(
        help="Replace existing fit groups in the HDF5 file, and an existing --csv file.")] = False,
    no_write: Annotated[bool, typer.Option(
        "--no-write", help="Do not write the fits into the HDF5 file.")] = False,
    stream: Annotated[str | None, typer.Option(
        help="Fit responses of this sampled stream of the HDF5 file (any stream, in its own "
             "units) over the trials' annotated regions or steps found in it, instead of "
             "event counts. Nothing is written into the file.", show_default=False)] = None,
    channels: Annotated[str | None, typer.Option(
        help="Channels of --stream to fit: glob(s), comma-separated, e.g. 'fz_*'; "
             "default all.", show_default=False)] = None,
    reduce: Annotated[Reduce, typer.Option(
        help="With --stream: fit every channel (none) or the channels' mean.")] = Reduce.none,
    region_label: Annotated[str | None, typer.Option(
        help="With --stream: fit the regions with this label (an annotation's, e.g. press; "
             "found ones are rise, fall, or pulse with --model pulse); default all.",
        show_default=False)] = None,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    min_snr: Annotated[float | None, typer.Option(
        min=0.001, help="With --stream --regions detect/auto: a step's change over ~1.6 time "
        "constants must exceed this many times its noise; default 8.", show_default=False)] = None,
    max_curves: Annotated[int | None, typer.Option(
        min=1, help="With --stream: most curves (trial x channel x region) to search or fit; "
                    "default 4096 (about 20 s); more are refused with the time they would "
                    "take.", show_default=False)] = None,
) -> None:
    """Fit first-order-system models to the press (eq. 16) and slip (eq. 17) regions of
    every trial, all trials at once (paper 000, sec. 4.2).

    Per trial: alpha and tau with standard errors, the press length T, Pearson R, the
    solver's status and steps, and whether a second order fits better (BIC). An HDF5 file
    gets the results in /derived/fits/fos_press and fos_slip (validated copy, then
    renamed over the file). The slip's counts have the extrapolated press response
    subtracted before eq. 17 is fitted. CSV curves are fitted with --model, all in one
    batch, in the unit of their header or --units. The solver is traced and compiled once
    and kept in $TACTILE_CACHE_DIR (default ~/.cache/tactile; --help of --solver shows
    where), so later runs load it instead.

    Several HDF5 files are fitted one task per file on Dask (--workers, --scheduler), each
    written into its own file; a file already fitted with the same settings is skipped,
    a failed file is named on one line while the others are fitted (exit 2).
    """


    def body() -> None:
        from contextlib import ExitStack

        from ..fos.fit_files import fit_files
        from ..fos.text import batch_line, fit_blocks
        from ._batch import FileBatchPrinter, finish_batch

        printer = FileBatchPrinter("fit-fos", progress=None, todo="to fit",
                                   describe=lambda item: batch_line(item.value),
                                   flags=lambda t: spell(t, FLAGS))
        with ExitStack() as stack:
            def on_plan(items: list[Any]) -> None:  # a batch: its bar and lines from here
                stack.enter_context(printer.running())
                printer.on_plan(items)

            result = fit_files(
                files, kind=kind, regions=regions, model=model, units=units,
                bin_s=None if bin_ms is None else bin_ms / 1000,
                press_duration_s=press_duration, solver=solver, max_steps=max_steps,
                rtol=rtol, atol=atol, p0=p0, order=order, csv=csv_out, plot=plot,
                overwrite=overwrite, write=not no_write, stream=stream, channels=channels,
                reduce=reduce, region_label=region_label, min_snr=min_snr,
                max_curves=max_curves, scheduler=scheduler, workers=workers,
                records=as_json, progress=Spinner(), on_plan=on_plan,
                on_progress=printer.on_progress, on_item=printer.on_item)
        if result.batch is not None:
            finish_batch(result.batch, as_json=as_json)
        elif as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2, allow_nan=False))
        else:
            print_blocks(fit_blocks(result, plot), width=160)

    run_guarded(body, flags=FLAGS)
