"""`tactile fit-fos FILE`"""

from __future__ import annotations

import enum
import json
import sys
from collections import Counter
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from ..errors import InputError
from ..fos.compile_cache import cache_root, enable_compilation_cache
from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption
from ._errors import COMMON_FLAGS, Flag, run_guarded, seconds_as_ms, to_flags

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "bin_s": ("--bin-ms", seconds_as_ms),
    "regions": "--regions",
    "channels": "--channels",
    "reduce": "--reduce",
    "region_label": "--region-label",
    "min_snr": "--min-snr",
    **BATCH_FLAGS,
}


class Kind(enum.StrEnum):
    press = "press"
    slip = "slip"
    both = "both"


class Regions(enum.StrEnum):
    annotations = "annotations"
    detect = "detect"
    auto = "auto"


class Solver(enum.StrEnum):
    levenberg_marquardt = "levenberg_marquardt"
    gauss_newton = "gauss_newton"


class Reduce(enum.StrEnum):
    none = "none"
    mean = "mean"


class CurveModel(enum.StrEnum):
    pulse = "pulse"
    step = "step"
    ramp = "ramp"


#: Rows of the table printed in full; beyond it converged rows are elided (failed never are).
MAX_ROWS = 60


def _pm(value: Any, se: Any, fmt: str) -> str:
    if value is None:
        return "-"
    return f"{value:{fmt}}" + (f" ± {se:{fmt}}" if se is not None else "")


def _summary(records: list[dict[str, Any]]) -> dict[str, Any]:
    import numpy as np

    ok = [r for r in records if r["status"] == "converged"]
    r_values = [r["pearson_r"] for r in ok if r["pearson_r"] is not None]
    return {
        "n_trials": len(records),
        "n_converged": len(ok),
        "n_failed": len(records) - len(ok),
        "median_pearson_r": float(np.median(r_values)) if r_values else None,
        "min_pearson_r": float(np.min(r_values)) if r_values else None,
        "status_counts": dict(Counter(r["status"] for r in records)),
        "verdict_counts": dict(Counter(r["order_verdict"] for r in records)),
    }


def _verdict_cell(r: dict[str, Any]) -> str:
    """The order verdict; a relaxation with its share and time constant."""
    if r["order_verdict"] == "relaxation" and r.get("relax_fraction") is not None:
        return (f"relaxation ({100 * r['relax_fraction']:.0f} % over "
                f"{r['relax_tau_s']:.3g} s)")
    return r["order_verdict"]


def _units_of(records: list[dict[str, Any]]) -> str | None:
    """The one unit of every row, or None when the rows differ (curves in several units)."""
    units = {r["units"] for r in records}
    return units.pop() if len(units) == 1 else None


def _print_region(console: Console, region: str, model: str, records: list[dict[str, Any]],
                  summary: dict[str, Any], group: str | None) -> None:
    equation = {"pulse": "eq. 16", "ramp": "eq. 17"}.get(model, "eq. 16, T -> inf")
    table = Table(title=f"{region}: {model} ({equation})")
    units = _units_of(records)
    short = {"events/bin": "ev/bin"}.get(units or "", units)
    columns = [("trial", "left"), ("force", "right"),
               (f"alpha ({short})" if units else "alpha", "right"),
               ("tau (s)", "right"), ("T (s)", "right"), ("R", "right"),
               (f"s ({short})" if units else "s", "right"),
               (f"RSS ({short})^2" if units else "RSS", "right"),
               ("status", "left"), ("steps", "right"), ("order", "left")]
    if units is None:
        columns.insert(2, ("units", "left"))
    per_channel = any("channel" in r for r in records)
    if per_channel:
        columns[1:1] = [("channel", "left"), ("region", "left")]
    has_force = any(r.get("force_level", r.get("force_grade")) is not None for r in records)
    if not has_force:
        columns.pop(3 if per_channel else 1)
    for col, justify in columns:
        table.add_column(col, justify=justify)
    failed = [r for r in records if r["status"] != "converged"]
    shown = records
    if len(records) > MAX_ROWS:
        keep = {id(r) for r in records[:20] + records[-20:] + failed}
        shown = [r for r in records if id(r) in keep]
    for r in shown:
        bad = r["status"] != "converged"
        force = r.get("force_level", r.get("force_grade", ""))
        cells = [
            str(r["trial"]), "" if force is None else str(force),
            _pm(r["alpha"], r["alpha_se"], ".1f" if r["units"] == "events/bin" else ".4g"),
            _pm(r["tau_s"], r["tau_se"], ".4f"),
            _pm(r["duration_s"], r["duration_se"], ".3f") if model == "pulse" else "",
            "-" if r["pearson_r"] is None else f"{r['pearson_r']:.5f}",
            _pm(r["residual_std"], None, ".4g"), _pm(r["rss"], None, ".4g"),
            f"[red]{r['status']}[/]" if bad else r["status"], str(r["n_steps"]),
            _verdict_cell(r),
        ]
        if units is None:
            cells.insert(2, r["units"])
        if per_channel:
            cells[1:1] = [str(r["channel"]), str(r["region"])]
        if not has_force:
            cells.pop(3 if per_channel else 1)
        table.add_row(*cells)
    if len(shown) < len(records):
        table.caption = (f"{len(records) - len(shown)} converged trials not shown; "
                         "use --json or --csv for all")
    console.print(table)
    for status, n in summary["status_counts"].items():
        if status != "converged":
            message = next(r["status_message"] for r in records if r["status"] == status)
            console.print(f"  [red]{status}[/] ({n} trial(s)): {message}")
    median = summary["median_pearson_r"]
    verdicts = ", ".join(f"{k} {v}" for k, v in sorted(summary["verdict_counts"].items()))
    console.print(
        f"{region}: {summary['n_converged']} converged, {summary['n_failed']} failed; "
        f"median R {'-' if median is None else f'{median:.5f}'}; order: {verdicts}"
        + (f"; written to {group}" if group else "")
    )


def fit_fos_command(
    files: Annotated[list[Path], typer.Argument(
        help="A tactile HDF5 file, or CSV curves fitted together: files or folders of "
             "them, each a header, then t in s and one or more response columns "
             "(t,x1,x2,...).",
        show_default=False, metavar="FILE")],
    kind: Annotated[Kind | None, typer.Option(
        help="Regions to fit (HDF5): press, slip or both; default both.",
        show_default=False)] = None,
    regions: Annotated[Regions | None, typer.Option(
        help="Where the regions come from (HDF5): the trials' annotations, detected in the "
             "counts (with --stream: steps found in the signal), or auto (annotations where "
             "present; the default; with --stream the default is annotations).",
        show_default=False)] = None,
    bin_ms: Annotated[float | None, typer.Option(
        min=0.001, help="Bin width in ms (HDF5); default 20 for events, a count stream's "
                        "own width.", show_default=False)] = None,
    model: Annotated[CurveModel | None, typer.Option(
        help="Model for CSV curves and --stream: pulse (eq. 16), step or ramp (eq. 17); "
             "--stream defaults to step.", show_default=False)] = None,
    units: Annotated[str | None, typer.Option(
        help="Unit of the CSV curves' response (and so of alpha); default: the unit in the "
             "response column's header, as in 'force (N)', else 'units'.",
        show_default=False)] = None,
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
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
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
        help="With --stream: fit every channel (none) or the channels' mean.")
    ] = Reduce.none,
    region_label: Annotated[str | None, typer.Option(
        help="With --stream: fit the regions with this label (an annotation's, e.g. press; "
             "found ones are rise, fall, or pulse with --model pulse); default all.",
        show_default=False)] = None,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    min_snr: Annotated[float | None, typer.Option(
        min=0.001, help="With --stream --regions detect/auto: a step's change over "
                        "~1.6 time constants must exceed this many times its noise; "
                        "default 8.", show_default=False)] = None,
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
        from ..fos.curve_csv import csv_inputs
        from ..store.outdir import check_output_folder
        from ..store.trials import is_hdf5

        options()  # bad --rtol, --atol or --p0: one line before any file is read

        for file in files:
            if not (file.is_file() or file.is_dir()):
                raise InputError("file not found", path=file)
        if plot is not None:  # figures are added to an existing folder; a file there is not
            check_output_folder(plot, merge=True)
        if csv_out is not None and csv_out.is_dir():
            raise InputError("is a folder; give a file name for --csv", path=csv_out)
        if csv_out is not None and csv_out.exists() and not overwrite:
            raise InputError("output exists; pass --overwrite to replace it", path=csv_out)
        hdf5 = [f for f in files if f.is_file() and is_hdf5(f)]
        if stream is None:
            for flag, value in (("--channels", channels), ("--region-label", region_label),
                                ("--reduce", None if reduce == Reduce.none else reduce),
                                ("--min-snr", min_snr)):
                if value is not None:
                    raise InputError(f"{flag} applies with --stream NAME (a sampled stream "
                                     "of an HDF5 file)")
        if stream is not None:
            if not hdf5 or len(files) > 1:
                raise InputError("--stream fits a sampled stream of one tactile HDF5 file",
                                 path=files[0])
            for flag, value in (("--kind", kind), ("--bin-ms", bin_ms), ("--units", units)):
                if value is not None:
                    raise InputError(f"{flag} does not apply with --stream: the stream's "
                                     "regions are fitted with --model, in the stream's units",
                                     path=files[0])
            if press_duration is not None and model != CurveModel.pulse:
                raise InputError("--press-duration applies with --model pulse", path=files[0])
            _report(_fit_stream(hdf5[0]))
            return
        if hdf5 and (len(files) > 1 or scheduler is not None or workers is not None):
            # an unreadable file among tactile files is one of them: its task says why; one
            # file with --scheduler/--workers (a glob that matched one) is a batch of one
            curves = [f for f in files if f.is_dir() or f.suffix.lower() == ".csv"]
            if curves:
                other = curves[0]
                raise InputError("several inputs must all be tactile HDF5 files (fitted one "
                                 "task per file) or all CSV curves (fitted together)",
                                 path=other)
            _fit_many(files)
            return
        if scheduler is not None or workers is not None:
            raise InputError("--scheduler and --workers go with tactile HDF5 files (one "
                             "task per file)", path=files[0])
        if hdf5:
            file = hdf5[0]
            for flag, value in (("--model", model), ("--units", units)):
                if value is not None:
                    raise InputError(f"{flag} applies to CSV curves; an HDF5 file's press "
                                     "regions are fitted with the pulse (eq. 16), slips with "
                                     "the ramp (eq. 17), in events per bin", path=file)
            result = _fit_h5(file)
        else:
            for flag, value in (("--kind", kind), ("--regions", regions), ("--bin-ms", bin_ms)):
                if value is not None:
                    raise InputError(f"{flag} applies to HDF5 files; a CSV is one curve "
                                     "fitted with --model", path=files[0])
            if model is None:
                raise InputError("a CSV curve needs --model pulse, step or ramp", path=files[0])
            result = _fit_csv(csv_inputs(files))
        _report(result)

    def options() -> Any:
        from ..fos.fit import FitOptions

        tols = {}
        for flag, value in (("rtol", rtol), ("atol", atol)):
            if value is not None:
                if not (0 < value < 1):  # NaN fails too
                    raise InputError(f"--{flag} {value:g} must be a tolerance in (0, 1), "
                                     "e.g. 1e-10")
                tols[flag] = value
        try:
            return FitOptions(solver=solver.value, max_steps=max_steps, p0=_parse_p0(p0),
                              **tols)
        except ValueError as e:
            raise InputError(str(e).replace("`p0`", "--p0")) from None

    def config() -> dict[str, Any]:
        opts = options()
        default_regions = Regions.annotations if stream is not None else Regions.auto
        return {"kind": (kind or Kind.both).value,
                "regions": (regions or default_regions).value,
                "model": None if model is None else model.value, "min_snr": min_snr,
                "bin_ms": bin_ms, "press_duration_s": press_duration, "solver": solver.value,
                "max_steps": max_steps, "rtol": opts.rtol, "atol": opts.atol,
                "p0": None if opts.p0 is None else dict(opts.p0), "order": order,
                "criterion": "bic", "units": units, "stream": stream, "channels": channels,
                "reduce": reduce.value, "region_label": region_label}

    def _fit_many(paths: list[Path]) -> None:
        from ..fos.batch import fit_each
        from ._batch import FileBatchPrinter, finish_batch

        for flag, value in (("--model", model), ("--units", units), ("--csv", csv_out),
                            ("--plot", plot), ("--no-write", no_write or None)):
            if value is not None:
                raise InputError(f"{flag} goes with one HDF5 file; several files are fitted "
                                 "one task per file, each written into its file",
                                 path=paths[0])

        def describe(item: Any) -> str:
            parts = []
            for region, s in item.value["summary"].items():
                median = s["median_pearson_r"]
                parts.append(f"{region} {s['n_converged']}/{s['n_trials']} converged"
                             + ("" if median is None else f" (median R {median:.4f})"))
            return "; ".join(parts)

        wanted = ["press", "slip"] if (kind or Kind.both) == Kind.both else [kind.value]
        printer = FileBatchPrinter("fit-fos", progress=None, todo="to fit",
                                   describe=describe,
                                   flags=lambda t: to_flags(t, {**COMMON_FLAGS, **FLAGS}))
        with printer.running():
            result = fit_each(
                paths, regions=wanted, region_source=(regions or Regions.auto).value,
                bin_s=None if bin_ms is None else bin_ms / 1000,
                press_duration_s=press_duration, order=order, options=options(),
                overwrite=overwrite, config=config(), records=as_json,
                scheduler=scheduler, workers=workers, on_plan=printer.on_plan,
                on_progress=printer.on_progress, on_item=printer.on_item)
        finish_batch(result, as_json=as_json)

    def _fit_h5(path: Path) -> dict[str, Any]:
        from ..fos.fit_file import fit_fos_file
        from ..fos.table import fit_records

        wanted = ["press", "slip"] if (kind or Kind.both) == Kind.both else [kind.value]
        enable_compilation_cache()
        with _Status("fitting (the first run compiles the solvers)"):
            result = fit_fos_file(
                path, regions=wanted, region_source=(regions or Regions.auto).value,
                bin_s=None if bin_ms is None else bin_ms / 1000,
                press_duration_s=press_duration, order=order, options=options(),
                write=not no_write, overwrite=overwrite, config=config())
        return {"files": [str(path)], "input": "hdf5", "bin_s": result.bin_s,
                "fits": result.fits, "labels": result.labels,
                "records": {r: fit_records(result.fits[r], result.labels) for r in wanted},
                "written": result.written}

    def _fit_csv(paths: list[Path]) -> dict[str, Any]:
        from ..fos.curve_csv import read_curves
        from ..fos.protocol import DEFAULT_UNITS, fit_curves
        from ..fos.table import fit_records

        curves, where = [], {}
        for p in paths:
            for c in read_curves(p):
                if c.name in where:
                    raise InputError(f"two curves are named {c.name!r} ({where[c.name]} and "
                                     "this file); rows and figures are named after the file "
                                     "(and column), so rename one", path=p)
                where[c.name] = p
                curves.append(c)
        enable_compilation_cache()
        with _Status("fitting (the first run compiles the solver)"):
            rf = fit_curves([(c.t_s, c.x) for c in curves], model=model.value,
                            names=[c.name for c in curves],
                            units=[units or c.units or DEFAULT_UNITS for c in curves],
                            press_duration_s=press_duration, order=order, options=options())
        return {"files": [str(p) for p in paths], "input": "csv", "bin_s": None,
                "fits": {"curve": rf}, "labels": None, "records": {"curve": fit_records(rf)},
                "written": {}, "quantities": [c.quantity for c in curves]}

    def _fit_stream(path: Path) -> dict[str, Any]:
        from ..fos.protocol import fit_curves
        from ..fos.stream import read_stream_curves
        from ..fos.table import fit_records

        chosen = (model or CurveModel.step).value
        found = read_stream_curves(
            path, stream, channels=channels, reduce=reduce.value, region_label=region_label,
            regions=(regions or Regions.annotations).value, model=chosen,
            **({} if min_snr is None else {"min_snr": min_snr}))
        curves = found.curves
        enable_compilation_cache()
        with _Status("fitting (the first run compiles the solver)"):
            rf = fit_curves([(c.t_s, c.x) for c in curves], model=chosen,
                            names=[c.name for c in curves], units=[c.units for c in curves],
                            press_duration_s=press_duration, order=order, options=options())
        records = fit_records(rf)
        for c, rec in zip(curves, records, strict=True):
            rec.update({"trial": c.trial, "channel": c.channel, "region": c.region,
                        "stream": stream, "baseline": c.baseline,
                        "region_start_s": c.start_s, "region_end_s": c.end_s})
        return {"files": [str(path)], "input": "stream", "bin_s": None,
                "fits": {stream: rf}, "labels": None, "records": {stream: records},
                "written": {}, "quantities": [stream] * len(curves),
                "no_step": {stream: found.no_step},
                "not_fitted": {stream: found.not_fitted}}

    def _report(result: dict[str, Any]) -> None:
        from ..fos.table import write_csv

        summaries = {r: _summary(recs) for r, recs in result["records"].items()}
        figures: list[str] = []
        if plot is not None:
            from ..fos.plots import plot_curve_fits, plot_region_fits
            from ..store.outdir import output_folder

            with output_folder(plot, merge=True) as tmp:  # in place when every page is
                for region, rf in result["fits"].items():
                    if region == "curve" or result["input"] == "stream":
                        pages = plot_curve_fits(rf, tmp, quantities=result["quantities"])
                    elif region in result["records"]:
                        pages = plot_region_fits(rf, tmp, labels=result["labels"])
                    else:
                        continue
                    figures += [str(plot / p.name) for p in pages]
        if csv_out is not None:
            write_csv(csv_out, [rec for recs in result["records"].values() for rec in recs])
        if as_json:
            paths = result["files"]
            out = {
                "file": paths[0] if len(paths) == 1 else None, "files": paths,
                "input": result["input"], "bin_s": result["bin_s"], "config": config(),
                "regions": {
                    region: {"model": result["fits"][region].model,
                             "group": result["written"].get(region),
                             "summary": summaries[region], "fits": recs,
                             **({"no_step": result["no_step"][region],
                                 "not_fitted": result["not_fitted"][region]}
                                if "no_step" in result else {})}
                    for region, recs in result["records"].items()},
                "csv": None if csv_out is None else str(csv_out), "figures": figures,
            }
            typer.echo(json.dumps(out, indent=2, allow_nan=False))
            return
        console = Console(width=None if sys.stdout.isatty() else 160)
        for region, recs in result["records"].items():
            _print_region(console, region, result["fits"][region].model, recs,
                          summaries[region], result["written"].get(region))
            missed = result.get("no_step", {}).get(region, [])
            if missed:
                shown = ", ".join(missed[:10]) + (f", ... ({len(missed)} in all)"
                                                  if len(missed) > 10 else "")
                console.print(f"  no step found (not fitted) in {len(missed)} curve(s): "
                              f"{shown}", markup=False, highlight=False)
            why = result.get("not_fitted", {}).get(region, {})
            for curve, reason in list(why.items())[:MAX_ROWS]:
                console.print(f"    {curve}: {reason}", markup=False, highlight=False)
            if len(why) > MAX_ROWS:
                console.print(f"    ... {len(why) - MAX_ROWS} more; use --json for all",
                              markup=False, highlight=False)
        if csv_out is not None:
            console.print(f"wrote {csv_out}")
        if figures:
            console.print(f"wrote {len(figures)} figure(s) to {plot}")

    run_guarded(body, flags=FLAGS)


def _parse_p0(text: str | None) -> dict[str, float] | None:
    """``"alpha=2,tau=0.05"`` -> ``{"alpha": 2.0, "tau": 0.05}``; one-line errors."""
    from ..fos.fit import P0_NAMES

    if text is None:
        return None
    out: dict[str, float] = {}
    for item in text.split(","):
        name, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not name:
            raise InputError(f"--p0 {text!r}: expected name=value pairs separated by commas, "
                             "e.g. 'tau=0.05,T=0.3'")
        if name not in P0_NAMES:
            raise InputError(f"--p0 names {name!r}; the starting values are "
                             f"{', '.join(P0_NAMES)}")
        if name in out:
            raise InputError(f"--p0 gives {name} twice")
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"--p0 {name}={value!r} is not a number") from None
    return out


class _Status:
    """A spinner on stderr while the fit runs (only when stderr is a terminal)."""

    def __init__(self, message: str):
        self.message = message
        self._status = None

    def __enter__(self) -> _Status:
        if sys.stderr.isatty():
            self._status = Console(stderr=True).status(self.message)
            self._status.__enter__()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._status is not None:
            self._status.__exit__(*exc)
